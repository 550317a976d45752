// mpmrom stability: where the FOM and each ROM configuration break (docs/stability.md).
#include <cstdio>
#include <memory>
#include <string>

#include "studies/stability.hpp"

#include "command.hpp"
#include "common.hpp"

namespace mpmrom::cli {
namespace {

struct Options {
  StabilitySettings stability_settings;
  std::string stability_selection = "auto";  // each method's default (rom_defaults)
};

// o is a copy: the run completes its settings.
int run(Options o, const Context& context) {
  const bool quiet = context.quiet;
  if (o.stability_selection != "auto")
    o.stability_settings.selection = mpmrom::sample_selection_from_string(o.stability_selection);
  std::size_t done = 0;
  const auto cases = mpmrom::run_stability(o.stability_settings, [&](const mpmrom::StabilityCase& c) {
    if (quiet) return;
    std::fprintf(
        stderr,
        "mpmrom stability: %3zu %-9s %-18s cfl %-4g h %-3gx d %-5g load %-3g %-8s %-12s %s%.3g %% (%.2f s)%s%s\n",
        ++done, c.study.c_str(), c.config.c_str(), c.cfl, c.horizon, c.extrapolation, c.load_factor,
        c.material.empty() ? "scene" : c.material.c_str(), c.status.c_str(), "", 100 * c.position_error, c.seconds,
        c.cause.empty() ? "" : ": ", c.cause.substr(0, 90).c_str());
  });
  if (!quiet)
    print_stderr("mpmrom stability: %zu cases; wrote %s/stability.md, stability.json and the charts\n", cases.size(),
                 o.stability_settings.out_dir.c_str());
  return 0;
}

}  // namespace

void add_stability(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "stability",
      "Stability map: where the FOM and each ROM configuration break (time step, horizon, extrapolation, "
      "samples, material, load)");
  add_input(command, "scene", o->stability_settings.scene_path, "Scene file (TOML) of the sweep the model learned");
  add_input(command, "--model", o->stability_settings.model_path, "Model file (from mpmrom train)");
  command
      ->add_option("--data", o->stability_settings.data_dir,
                   "The sweep the model was trained on (for --selection greedy)")
      ->check(CLI::ExistingDirectory);
  command->add_option("--out", o->stability_settings.out_dir, "Output directory (stability.md, .json, charts)")
      ->required();
  add_defaulted(command, "--samples", o->stability_settings.samples,
                "Sample points of the hyper-reduced configurations");
  add_defaulted(command, "--selection", o->stability_selection,
                "Sample selection: auto (each method's default, as a rollout without flags), or one of the rollout's "
                "--selection values for both methods");
  add_defaulted(command, "--threshold", o->stability_settings.threshold,
                "Position error (fraction) above which a run counts as inaccurate");
  add_defaulted(command, "--fom-cfl", o->stability_settings.fom_cfl, "FOM time steps (CFL numbers)");
  add_defaulted(command, "--rom-cfl", o->stability_settings.rom_cfl, "ROM time steps (CFL numbers)");
  add_defaulted(command, "--extrapolation", o->stability_settings.extrapolation,
                "Distances beyond the training range, in widths (-0.5: its centre)");
  add_defaulted(command, "--horizons", o->stability_settings.horizons, "Horizons, in training windows");
  add_defaulted(command, "--load-factors", o->stability_settings.load_factors,
                "Factors on the first design parameter for Algorithm 2's inversion");
  command->footer("Example: mpmrom stability scenes/poke_cylinder.toml --model model.h5 --data data/poke --out map");
  commands.push_back({command, nullptr, [o](const Context& context) { return run(*o, context); }});
}

}  // namespace mpmrom::cli
