// mpmrom pipeline: sweep, FOM resolutions, training, ROM configurations and the report (docs/pipeline.md).
#include <memory>
#include <string>
#include <vector>

#include "studies/pipeline.hpp"

#include "command.hpp"
#include "common.hpp"

namespace mpmrom::cli {
namespace {

struct Options {
  PipelineSettings pipeline_settings;
  std::vector<std::string> pipeline_networks, pipeline_methods;
};

// o is a copy: the run completes its settings.
int run(Options o, const Context& context) {
  const bool quiet = context.quiet;
  for (const auto& text : o.pipeline_networks)
    o.pipeline_settings.networks.push_back(mpmrom::NetworkShape::parse(text));
  if (!o.pipeline_methods.empty()) {
    o.pipeline_settings.methods.clear();
    for (const auto& m : o.pipeline_methods) o.pipeline_settings.methods.push_back(mpmrom::rom_method_from_string(m));
  }
  o.pipeline_settings.command = "mpmrom";
  for (int a = 1; a < context.argc; ++a) o.pipeline_settings.command += std::string(" ") + context.argv[a];
  mpmrom::run_pipeline(o.pipeline_settings, log_lines(quiet));
  return 0;
}

}  // namespace

void add_pipeline(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "pipeline", "The whole chain: sweep, FOM resolutions, training, ROM configurations, report with charts");
  add_input(command, "scene", o->pipeline_settings.scene_path, "Scene file (TOML) with a [design] table");
  command->add_option("--out", o->pipeline_settings.out_dir, "Output directory (report.md, report.json, charts, data)")
      ->required();
  add_defaulted(command, "--fom-refinements", o->pipeline_settings.fom_refinements,
                "FOM resolutions, as factors on the scene's (grid and particle spacing divided by each)");
  add_defaulted(command, "--fom-cfl", o->pipeline_settings.fom_cfls, "CFL numbers of the FOM ladder (0: the scene's)");
  add_defaulted(command, "--reference-refinement", o->pipeline_settings.reference_refinement,
                "Resolution factor of the reference FOM that every error is measured against");
  command->add_option("--networks", o->pipeline_networks,
                      "Networks to train, r x width x depth (e.g. 5x48x5 3x16x5); default: train's defaults, or "
                      "r in {3,5,8} x width in {16,32,48} with --target-error");
  add_defaulted(command, "--epochs", o->pipeline_settings.training.epochs, "Training epochs per network");
  add_loss_weights(command, o->pipeline_settings.training.lambda_gradient,
                   o->pipeline_settings.training.lambda_velocity, o->pipeline_settings.training.lambda_affine);
  add_defaulted(command, "--methods", o->pipeline_methods,
                "ROM algorithms: point (Algorithm 1), node (Algorithm 2), galerkin; default: point galerkin");
  add_defaulted(command, "--samples", o->pipeline_settings.samples, "Sample counts to try (0: all points)");
  add_defaulted(command, "--rom-cfl", o->pipeline_settings.rom_cfls, "ROM time steps as CFL numbers (0: the scene's)");
  add_defaulted(command, "--validation-runs", o->pipeline_settings.validation_runs,
                "Training runs held out to choose models (-1: a sixth)");
  command
      ->add_option("--target-error", o->pipeline_settings.target_errors,
                   "Search for the cheapest ROM meeting each validation position error (fractions)")
      ->check(CLI::PositiveNumber);
  add_defaulted(command, "--batch-sizes", o->pipeline_settings.batch_sizes, "Batch sizes of the throughput benchmark");
  command->footer(
      "Example: mpmrom pipeline scenes/poke_cylinder.toml --out out/pipeline\n"
      "         mpmrom pipeline scenes/poke_cylinder.toml --out out/search --target-error 0.01 0.003");
  commands.push_back({command, nullptr, [o](const Context& context) { return run(*o, context); }});
}

}  // namespace mpmrom::cli
