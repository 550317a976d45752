// mpmrom: the command-line front end. Parsing and printing only; the work is done by the library.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <exception>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <unistd.h>

#include "io/atomic_file.hpp"
#include "bench/bench.hpp"
#include "analysis/evaluation.hpp"
#include "studies/pipeline.hpp"
#include "mpmrom/rom.hpp"
#include "rom/rom_file.hpp"
#include "mpmrom/mpmrom_config.hpp"
#include "core/parallel.hpp"
#include "mpmrom/runtime.hpp"
#include "scene/sampling.hpp"
#include "snapshots/simulate.hpp"
#include "studies/stability.hpp"
#include "manifold/trainer.hpp"
#include "analysis/upgrade.hpp"

namespace {

nlohmann::json to_json(const mpmrom::RuntimeInfo& info) {
  return {{"version", info.version},       {"git_commit", info.git_commit},
          {"backend", info.backend},       {"threads", info.threads},
          {"device", info.device},         {"kokkos_version", info.kokkos_version},
          {"precision", info.precision}};
}

const std::map<std::string, mpmrom::P2GStrategy> kP2GStrategies{{"atomic", mpmrom::P2GStrategy::Atomic},
                                                                   {"scatter", mpmrom::P2GStrategy::ScatterView},
                                                                   {"tiled", mpmrom::P2GStrategy::Tiled}};
const char* const kP2GHelp =
    "Particle-to-grid accumulation: scatter (per-thread grid copies; bitwise reproducible; default on CPUs), atomic "
    "(straight into the grid; default on GPUs) or tiled (teams sum into shared-memory tiles, then the grid)";

std::string p2g_name(mpmrom::P2GStrategy strategy) {
  for (const auto& [name, value] : kP2GStrategies)
    if (value == strategy) return name;
  return "";
}

// How much goes to stderr: nothing (--quiet), progress lines thinned out when stderr is not a terminal (a log file),
// or every line (--verbose).
enum class Verbosity { quiet, normal, verbose };
Verbosity verbosity = Verbosity::normal;

bool every_progress_line() { return verbosity == Verbosity::verbose || isatty(STDERR_FILENO); }

// One progress line per tenth of a run (every frame on a terminal), with the rate and the time left.
void report_progress(const mpmrom::SimulationProgress& p, bool quiet) {
  if (quiet) return;
  const int tenth = std::max(1, p.num_frames / 10);
  if (!every_progress_line() && p.frame % tenth != 0 && p.frame != p.num_frames) return;
  const double rate = p.seconds > 0 ? double(p.steps) * double(p.num_particles) / p.seconds : 0;
  const double left = p.frame > 0 ? p.seconds * (p.num_frames - p.frame) / p.frame : 0;
  std::fprintf(stderr, "  frame %d/%d  t = %.4f s  %ld steps  %.3g particle-steps/s  %.1f s left\n", p.frame,
               p.num_frames, p.time, p.steps, rate, left);
}

std::string duration_string(double seconds) {
  char text[32];
  if (seconds < 60)
    std::snprintf(text, sizeof text, "%.0f s", seconds);
  else if (seconds < 3600)
    std::snprintf(text, sizeof text, "%dm%02ds", int(seconds) / 60, int(seconds) % 60);
  else
    std::snprintf(text, sizeof text, "%dh%02dm", int(seconds) / 3600, int(seconds) % 3600 / 60);
  return text;
}

// One line per epoch on a terminal, about 20 per run otherwise (and every validated epoch).
void report_training(const mpmrom::TrainingProgress& p, bool quiet) {
  if (quiet) return;
  const int twentieth = std::max(1, p.epochs / 20);
  if (!every_progress_line() && !p.validated && p.epoch % twentieth != 0 && p.epoch != p.epochs) return;
  std::fprintf(stderr, "  epoch %d/%d  loss %.3e (x %.2e F %.2e v %.2e)", p.epoch, p.epochs, p.train.total,
               p.train.position, p.train.gradient, p.train.velocity);
  if (p.validated) std::fprintf(stderr, "  validation %.3e", p.validation.total);
  std::fprintf(stderr, "  lr %.1e  %.3g samples/s  %s left\n", p.learning_rate, p.samples_per_second,
               duration_string(p.seconds_left).c_str());
}

// Rollout cases from a parameter file (design.csv form: a column per parameter name, optional split) or, without
// one, the scene's design (or the scene as it is when it has none).
// One line for a failed allocation; Kokkos' own message runs over several, its first names the allocation.
std::string out_of_memory(const std::string& what) {
  return "mpmrom: error: out of memory (" + what.substr(0, what.find('\n')) +
         "): the run needs more memory than this machine or device has; use fewer points or a coarser grid\n";
}

std::vector<mpmrom::RolloutCase> rollout_cases(const mpmrom::Scene& scene, const std::string& params_path,
                                               std::vector<std::string>& names) {
  std::vector<mpmrom::RolloutCase> cases;
  names = scene.design.names;
  if (names.empty())
    for (const auto& [name, value] : scene.parameters) names.push_back(name);
  if (!params_path.empty()) {
    std::vector<std::vector<std::string>> columns;
    for (const auto& name : names) columns.push_back(mpmrom::design_column(params_path, name));
    std::vector<std::string> splits;
    try {
      splits = mpmrom::design_column(params_path, "split");
    } catch (const std::exception&) {
      // no split column: the rollouts' split stays unknown
    }
    const std::size_t rows = columns.empty() ? 0 : columns.front().size();
    for (std::size_t row = 0; row < rows; ++row) {
      mpmrom::RolloutCase c;
      for (std::size_t k = 0; k < names.size(); ++k) {
        try {
          std::size_t used = 0;
          c.values.push_back(std::stod(columns[k][row], &used));
          if (used != columns[k][row].size() || !std::isfinite(c.values.back()))
            throw std::invalid_argument("not a finite number");
        } catch (const std::exception&) {
          // rows counted as in a spreadsheet: the header is row 1
          throw std::runtime_error(params_path + ": row " + std::to_string(row + 2) + ", column '" + names[k] +
                                   "': '" + columns[k][row] + "' is not a finite number");
        }
      }
      if (!splits.empty()) c.split = splits[row];
      cases.push_back(c);
    }
    if (cases.empty()) throw std::runtime_error(params_path + ": no parameter rows");
    return cases;
  }
  if (!scene.design.names.empty()) {
    const auto runs = scene.design.all_runs();
    for (std::size_t r = 0; r < runs.size(); ++r) {
      bool test = false;
      for (const int t : scene.design.test_runs) test = test || std::size_t(t) == r;
      cases.push_back({runs[r], test ? "test" : "train"});
    }
    return cases;
  }
  mpmrom::RolloutCase c;
  for (const auto& name : names) c.values.push_back(scene.parameters.at(name));
  cases.push_back(c);
  return cases;
}

void print_metrics(const char* label, const nlohmann::json& e) {
  std::fprintf(stderr, "  %-8s position %.4f %%  displacement %.3f %%  velocity %.3f %%  F %.4f %%  strain %.3f %%\n", label,
               100 * e["position_error"].get<double>(), 100 * e["displacement_error"].get<double>(),
               100 * e["velocity_error"].get<double>(), 100 * e["F_error"].get<double>(),
               100 * e["strain_error"].get<double>());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mpmrom: material point method and its neural reduced-order model, on Kokkos"};
  app.set_version_flag("--version", std::string("mpmrom ") + MPMROM_VERSION_STRING + " (" + mpmrom::git_commit() +
                                        ", " + MPMROM_PRECISION_NAME + ")");
  app.require_subcommand(1);
  int threads = 0;
  int device = -1;
  app.add_option("--threads", threads, "CPU threads for the OpenMP backend (default: OMP_NUM_THREADS or all cores)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--device", device, "GPU index for the CUDA backend (default: 0)")->check(CLI::NonNegativeNumber);

  bool info_json = false;
  auto* info = app.add_subcommand("info", "Print the backend, device, threads and versions this build runs with");
  info->add_flag("--json", info_json, "One JSON object on stdout");
  info->footer("Example: mpmrom info --json");

  bool quiet = false, verbose = false;
  auto* quiet_flag = app.add_flag("-q,--quiet", quiet, "Nothing on stderr but errors and warnings");
  app.add_flag("-v,--verbose", verbose,
               "Every progress line (also when stderr is not a terminal), after a line naming the backend and device")
      ->excludes(quiet_flag);
  app.set_config("--config", "",
                 "Read options from a TOML file: top-level keys for global options, a [section] per subcommand "
                 "(docs/cli.md)");

  std::string scene_path, out_path;
  std::vector<std::string> overrides;
  mpmrom::P2GStrategy p2g = mpmrom::default_p2g_strategy();
  auto* simulate = app.add_subcommand("simulate", "Run the full-order MPM model on a scene; write one snapshot file");
  simulate->add_option("scene", scene_path, "Scene file (TOML)")->required()->check(CLI::ExistingFile);
  simulate->add_option("--out", out_path, "Snapshot file to write (HDF5; an XDMF side file goes next to it)")
      ->required();
  simulate->add_option("--set", overrides, "Override: parameter=value, or a scene entry like material.density=500");
  simulate->add_option("--p2g", p2g, kP2GHelp)
      ->transform(CLI::CheckedTransformer(kP2GStrategies, CLI::ignore_case));
  simulate->footer("Example: mpmrom simulate scenes/poke_cylinder.toml --out poke.h5 --set rho=1.2");

  std::string sweep_dir;
  bool sweep_resume = false;
  auto* sweep = app.add_subcommand("sweep", "Run the scene's parameter design: DIR/runs/*.h5 and DIR/design.csv");
  sweep->add_option("scene", scene_path, "Scene file (TOML) with a [design] table")->required()->check(CLI::ExistingFile);
  sweep->add_option("--out", sweep_dir, "Output directory")->required();
  sweep->add_option("--p2g", p2g, kP2GHelp)
      ->transform(CLI::CheckedTransformer(kP2GStrategies, CLI::ignore_case));
  sweep->add_flag("--resume", sweep_resume,
                  "Keep the runs a stopped sweep finished (same scene and parameters) and simulate the rest");
  sweep->footer("Example: mpmrom sweep scenes/poke_cylinder.toml --out data/poke");

  std::vector<std::string> train_inputs;
  std::string model_path;
  mpmrom::TrainingSettings training;
  bool resume = false;
  auto* train = app.add_subcommand("train", "Train the deformation map g(X; xhat) on full-order runs (loss (7))");
  train->add_option("data", train_inputs, "Sweep directories (design.csv splits train/test) or snapshot files")
      ->required()
      ->check(CLI::ExistingPath);
  train->add_option("--out", model_path, "Model file to write (HDF5)")->required();
  train->add_option("--latent", training.latent_dim, "Latent dimension r")->capture_default_str();
  train->add_option("--width", training.width, "Hidden units per layer")->capture_default_str();
  train->add_option("--depth", training.depth, "Affine layers (depth - 1 hidden ELU layers)")->capture_default_str();
  train->add_option("--lambda-grad", training.lambda_gradient, "lambda1: weight of the dg/dX - F misfit (relative)")
      ->capture_default_str();
  train->add_option("--lambda-vel", training.lambda_velocity,
                    "lambda2: weight of the dg/dxhat xhatdot - v misfit (relative)")
      ->capture_default_str();
  train->add_option("--epochs", training.epochs, "Epochs (each visits every training snapshot once)")
      ->capture_default_str();
  train->add_option("--batch-snapshots", training.batch_snapshots, "Snapshots per minibatch")->capture_default_str();
  train->add_option("--points-per-snapshot", training.points_per_snapshot, "Material points drawn per snapshot visit")
      ->capture_default_str();
  train->add_option("--learning-rate", training.learning_rate, "Adam learning rate, first epoch")
      ->capture_default_str();
  train->add_option("--final-learning-rate", training.final_learning_rate, "Adam learning rate, last epoch")
      ->capture_default_str();
  train->add_option("--validation", training.validation_fraction, "Fraction of material points held out")
      ->capture_default_str();
  train->add_option("--seed", training.seed, "Random seed (initial weights, minibatches, validation points)")
      ->capture_default_str();
  train->add_option("--checkpoint-seconds", training.checkpoint_seconds, "Seconds between checkpoints (MODEL.h5.ckpt)")
      ->capture_default_str();
  train->add_flag("--resume", resume, "Continue from MODEL.h5.ckpt, left by a run that was stopped");
  std::vector<double> target_errors;
  std::string search_scene;
  train->add_option("--target-error", target_errors,
                    "Search r, width and samples for the cheapest ROM whose validation position error meets this "
                    "(fraction, e.g. 0.01; several: the first decides MODEL.h5); needs --scene")
      ->check(CLI::PositiveNumber);
  train->add_option("--scene", search_scene, "Scene file of the sweep, for --target-error's rollouts")
      ->check(CLI::ExistingFile);
  std::vector<std::string> search_networks;
  train->add_option("--networks", search_networks,
                    "--target-error's networks, r x width x depth (default: r in {3,5,8} x width in {16,32,48})");
  bool train_json = false;
  train->add_flag("--json", train_json, "Print a benchmark record (device, time, settings, errors) as one JSON object on stdout");
  train->footer("Example: mpmrom train data/poke --out poke_model.h5\n"
                "         mpmrom train data/poke --out small.h5 --target-error 0.01 --scene scenes/poke_cylinder.toml\n"
                "Checkpoints go to MODEL.h5.ckpt while training and are removed once MODEL.h5 is written.");

  mpmrom::RomSettings rom_settings;
  std::string rom_method = "point", rom_selection = "greedy", params_path, rom_path, decode_mode = "none";
  std::vector<std::string> rom_data;
  double decode_spacing = 0;
  bool rollout_json = false;
  auto* rollout = app.add_subcommand("rollout", "Run the reduced model: one or many rollouts in one batch -> ROM.h5");
  rollout->add_option("model", model_path, "Model file (from mpmrom train)")->required()->check(CLI::ExistingFile);
  rollout->add_option("scene", scene_path, "Scene file (TOML) the model was trained on")
      ->required()
      ->check(CLI::ExistingFile);
  rollout->add_option("--out", rom_path, "ROM file to write (HDF5)")->required();
  rollout->add_option("--method", rom_method, "point (Algorithm 1, material-point-centric) or node (Algorithm 2)")
      ->capture_default_str();
  rollout->add_option("--samples", rom_settings.samples, "Sample material points for the projection; 0: all points")
      ->capture_default_str();
  rollout->add_option("--selection", rom_selection,
                      "Sample selection: greedy (from the model's stored ranking, or refitted to --data), region or "
                      "random")
      ->capture_default_str();
  rollout->add_option("--data", rom_data, "Full-order training runs (sweep directory) to refit --selection greedy to");
  rollout->add_option("--seed", rom_settings.seed, "Seed of --selection random")->capture_default_str();
  rollout->add_option("--params", params_path, "Parameter file (design.csv form); default: the scene's design")
      ->check(CLI::ExistingFile);
  rollout->add_option("--cfl", rom_settings.cfl, "Time step as a fraction of the CFL limit, up to 10 (0: the scene's; above 1 the FOM would be unstable)")
      ->capture_default_str();
  rollout->add_option("--end-time", rom_settings.end_time,
                      "Horizon (s), rounded to whole output intervals of the scene (0: the scene's end time)")
      ->capture_default_str();
  rollout->add_option("--margin", rom_settings.envelope_margin, "Cells of slack around the training motion")
      ->capture_default_str();
  rollout->add_option("--quadrature", rom_settings.quadrature_order, "Algorithm 2: Gauss points per axis per cell")
      ->capture_default_str();
  rollout->add_option("--newton-tolerance", rom_settings.newton_tolerance, "Algorithm 2: inversion tolerance, cells")
      ->capture_default_str();
  rollout->add_option("--projection-iterations", rom_settings.projection_iterations,
                      "Re-projections with dg/dxhat at the trial next state (0: the paper's, at xhat(t_n))")
      ->capture_default_str();
  rollout->add_option("--max-condition", rom_settings.max_condition,
                      "Condition estimate of the normal equations above which they are regularised (0: 0.01/epsilon)");
  rollout->add_flag("!--no-regularize", rom_settings.regularize,
                    "Stop a rollout at an ill-conditioned projection instead of regularising it");
  rollout->add_flag("!--no-inversion-fallback", rom_settings.inversion_fallback,
                    "Algorithm 2: drop a quadrature point whose inversion failed, without retrying");
  rollout->add_option("--max-failed-inversions", rom_settings.max_failed_inversions,
                      "Algorithm 2: stop when more than this fraction of the quadrature points fails in a step")
      ->capture_default_str();
  rollout->add_option("--energy-growth", rom_settings.energy_growth,
                      "Stop when |dxhat/dt| exceeds this times the fastest training motion (0: no check)")
      ->capture_default_str();
  rollout->add_option("--decode", decode_mode,
                      "Decoded fields to store: none, reference (the model's points) or lattice (--decode-spacing)")
      ->capture_default_str();
  rollout->add_option("--decode-spacing", decode_spacing, "Lattice spacing (m) of --decode lattice");
  rollout->add_flag("--json", rollout_json, "Print a benchmark record (timings, hyper-reduction) on stdout");
  mpmrom::RolloutCheckpoint rollout_checkpoint;
  rollout->add_option("--checkpoint-seconds", rollout_checkpoint.seconds,
                      "Seconds between checkpoints (ROM.h5.ckpt, at output frames)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  rollout->add_flag("--resume", rollout_checkpoint.resume, "Continue from ROM.h5.ckpt, left by a run that was stopped");
  rollout->footer("Example: mpmrom rollout poke_model.h5 scenes/poke_cylinder.toml --out rom.h5 --method node");

  std::vector<std::string> references;
  std::string evaluate_model;
  bool evaluate_json = false;
  auto* evaluate = app.add_subcommand("evaluate", "Errors of the rollouts in ROM.h5 against full-order reference runs");
  evaluate->add_option("rom", rom_path, "ROM file (from mpmrom rollout)")->required()->check(CLI::ExistingFile);
  evaluate->add_option("references", references, "Sweep directories or snapshot files")
      ->required()
      ->check(CLI::ExistingPath);
  evaluate->add_option("--model", evaluate_model, "Model file (default: the one ROM.h5 names)");
  evaluate->add_flag("--json", evaluate_json, "Print the errors as one JSON object on stdout");
  evaluate->footer("Example: mpmrom evaluate rom.h5 data/poke --json");

  std::vector<std::string> upgrade_files;
  auto* upgrade = app.add_subcommand(
      "upgrade", "Rewrite files of older mpmrom versions (variable-length strings) in the current formats, in place");
  upgrade->add_option("files", upgrade_files, "Snapshot, model or ROM files you trust (their origin: they are read "
                                              "with libhdf5's unchecked variable-length strings)")
      ->required()
      ->check(CLI::ExistingFile);
  upgrade->footer("Example: mpmrom upgrade data/poke/runs/*.h5 poke_model.h5");

  mpmrom::StabilitySettings stability_settings;
  std::string stability_selection = "greedy";
  auto* stability = app.add_subcommand(
      "stability", "Stability map: where the FOM and each ROM configuration break (time step, horizon, extrapolation, "
                   "samples, material, load)");
  stability->add_option("scene", stability_settings.scene_path, "Scene file (TOML) of the sweep the model learned")
      ->required()
      ->check(CLI::ExistingFile);
  stability->add_option("--model", stability_settings.model_path, "Model file (from mpmrom train)")
      ->required()
      ->check(CLI::ExistingFile);
  stability->add_option("--data", stability_settings.data_dir, "The sweep the model was trained on (greedy samples)")
      ->check(CLI::ExistingDirectory);
  stability->add_option("--out", stability_settings.out_dir, "Output directory (stability.md, .json, charts)")
      ->required();
  stability->add_option("--samples", stability_settings.samples, "Sample points of the hyper-reduced configurations")
      ->capture_default_str();
  stability->add_option("--selection", stability_selection, "Sample selection: region, random or greedy")
      ->capture_default_str();
  stability->add_option("--threshold", stability_settings.threshold,
                        "Position error (fraction) above which a run counts as inaccurate")
      ->capture_default_str();
  stability->add_option("--fom-cfl", stability_settings.fom_cfl, "FOM time steps (CFL numbers)")->capture_default_str();
  stability->add_option("--rom-cfl", stability_settings.rom_cfl, "ROM time steps (CFL numbers)")->capture_default_str();
  stability->add_option("--extrapolation", stability_settings.extrapolation,
                        "Distances beyond the training range, in widths (-0.5: its centre)")
      ->capture_default_str();
  stability->add_option("--horizons", stability_settings.horizons, "Horizons, in training windows")
      ->capture_default_str();
  stability->add_option("--load-factors", stability_settings.load_factors,
                        "Factors on the first design parameter for Algorithm 2's inversion")
      ->capture_default_str();
  stability->footer("Example: mpmrom stability scenes/poke_cylinder.toml --model model.h5 --data data/poke --out map");

  mpmrom::PipelineSettings pipeline_settings;
  std::vector<std::string> pipeline_networks, pipeline_methods;
  auto* pipeline = app.add_subcommand(
      "pipeline", "The whole chain: sweep, FOM resolutions, training, ROM configurations, report with charts");
  pipeline->add_option("scene", pipeline_settings.scene_path, "Scene file (TOML) with a [design] table")
      ->required()
      ->check(CLI::ExistingFile);
  pipeline->add_option("--out", pipeline_settings.out_dir, "Output directory (report.md, report.json, charts, data)")
      ->required();
  pipeline->add_option("--fom-refinements", pipeline_settings.fom_refinements,
                       "FOM resolutions, as factors on the scene's (grid and particle spacing divided by each)")
      ->capture_default_str();
  pipeline->add_option("--fom-cfl", pipeline_settings.fom_cfls, "CFL numbers of the FOM ladder (0: the scene's)")
      ->capture_default_str();
  pipeline->add_option("--reference-refinement", pipeline_settings.reference_refinement,
                       "Resolution factor of the reference FOM that every error is measured against")
      ->capture_default_str();
  pipeline->add_option("--networks", pipeline_networks,
                       "Networks to train, r x width x depth (e.g. 5x48x5 3x16x5); default: train's defaults, or "
                       "r in {3,5,8} x width in {16,32,48} with --target-error");
  pipeline->add_option("--epochs", pipeline_settings.training.epochs, "Training epochs per network")
      ->capture_default_str();
  pipeline->add_option("--methods", pipeline_methods, "ROM algorithms: point (1), node (2)")->capture_default_str();
  pipeline->add_option("--samples", pipeline_settings.samples, "Sample counts to try (0: all points)")
      ->capture_default_str();
  pipeline->add_option("--rom-cfl", pipeline_settings.rom_cfls, "ROM time steps as CFL numbers (0: the scene's)")
      ->capture_default_str();
  pipeline->add_option("--validation-runs", pipeline_settings.validation_runs,
                       "Training runs held out to choose models (-1: a sixth)")
      ->capture_default_str();
  pipeline->add_option("--target-error", pipeline_settings.target_errors,
                       "Search for the cheapest ROM meeting each validation position error (fractions)")
      ->check(CLI::PositiveNumber);
  pipeline->add_option("--batch-sizes", pipeline_settings.batch_sizes, "Batch sizes of the throughput benchmark")
      ->capture_default_str();
  pipeline->footer("Example: mpmrom pipeline scenes/poke_cylinder.toml --out out/pipeline\n"
                   "         mpmrom pipeline scenes/poke_cylinder.toml --out out/search --target-error 0.01 0.003");

  long bench_steps = 20, bench_warmup = 3;
  bool bench_json = false;
  auto* bench = app.add_subcommand("bench", "Time the solvers; --json prints one benchmark record on stdout");
  bench->require_subcommand(1);
  auto* bench_fom = bench->add_subcommand("fom", "Full-order MPM steps per second on a scene");
  bench_fom->add_option("scene", scene_path, "Scene file (TOML)")->required()->check(CLI::ExistingFile);
  bench_fom->add_option("--set", overrides, "Override: parameter=value, or a scene entry like grid.dx=0.02");
  bench_fom->add_option("--steps", bench_steps, "Timed steps")->check(CLI::PositiveNumber);
  bench_fom->add_option("--warmup", bench_warmup, "Untimed steps first")->check(CLI::NonNegativeNumber);
  bench_fom->add_option("--p2g", p2g, kP2GHelp)
      ->transform(CLI::CheckedTransformer(kP2GStrategies, CLI::ignore_case));
  mpmrom::P2GTiling tiling = mpmrom::default_p2g_tiling<mpmrom::FomSolver::ExecutionSpace>();
  bench_fom->add_option("--team-size", tiling.team_size, "Tiled P2G: threads per team")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  bench_fom->add_option("--particles-per-team", tiling.particles_per_team, "Tiled P2G: consecutive particles per team")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  bench_fom->add_option("--tile-nodes", tiling.max_tile_nodes, "Tiled P2G: largest tile (nodes) a team keeps in scratch")
      ->capture_default_str()
      ->check(CLI::Range(27, 1 << 20));
  mpmrom::ParticleOrder particle_order = mpmrom::default_particle_order();
  const std::map<std::string, mpmrom::ParticleOrder> particle_orders{{"sampling", mpmrom::ParticleOrder::Sampling},
                                                                     {"bricks", mpmrom::ParticleOrder::Bricks}};
  bench_fom->add_option("--order", particle_order, "How particles are stored: sampling (the scene's order) or bricks")
      ->transform(CLI::CheckedTransformer(particle_orders, CLI::ignore_case));
  bench_fom->add_flag("--json", bench_json, "One JSON record on stdout");
  bench_fom->footer("Example: mpmrom bench fom scenes/cylinder_1e6.toml --p2g scatter --json");

  mpmrom::NnBenchmarkSettings nn_bench;
  auto* bench_nn = bench->add_subcommand("nn", "Network kernels: forward-with-Jacobians evaluations/s, training samples/s");
  bench_nn->add_option("--latent", nn_bench.latent_dim, "Latent dimension r")->capture_default_str();
  bench_nn->add_option("--width", nn_bench.width, "Hidden units per layer")->capture_default_str();
  bench_nn->add_option("--depth", nn_bench.depth, "Affine layers")->capture_default_str();
  bench_nn->add_option("--points", nn_bench.points, "Points per evaluation batch")->capture_default_str();
  bench_nn->add_option("--codes", nn_bench.codes, "Latent codes per evaluation batch (rollouts)")->capture_default_str();
  bench_nn->add_option("--batch-snapshots", nn_bench.batch_snapshots, "Training minibatch: snapshots")
      ->capture_default_str();
  bench_nn->add_option("--points-per-snapshot", nn_bench.points_per_snapshot, "Training minibatch: points each")
      ->capture_default_str();
  bench_nn->add_option("--repeats", nn_bench.repeats, "Timed repetitions")->check(CLI::PositiveNumber);
  bench_nn->add_flag("--json", bench_json, "One JSON record on stdout");
  bench_nn->footer("Example: mpmrom bench nn --codes 1024 --json");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  // Under mpirun (an MPI build), sweep, train and rollout share their work among the ranks (docs/mpi.md); rank 0
  // reports and writes the outputs, the others say nothing but errors.
  mpmrom::parallel::Session mpi(argc, argv);
  const auto world = mpmrom::parallel::Communicator::world();
  // One rank's error ends them all: the others would wait for it in their next collective operation.
  const auto fail = [&world](int status) {
    if (world.size() > 1) world.abort(status);
    return status;
  };
  if (!world.is_root()) quiet = true;
  verbosity = quiet ? Verbosity::quiet : verbose ? Verbosity::verbose : Verbosity::normal;
  try {
    if (world.size() > 1 && !(*sweep || *rollout || (*train && target_errors.empty())))
      throw std::invalid_argument("under mpirun, mpmrom runs sweep, train and rollout (without --target-error); "
                                  "run the other commands as one process");
    mpmrom::KokkosSession kokkos(threads, device, world.local_rank());
    if (verbose) {
      const auto runtime = mpmrom::runtime_info();
      std::cerr << "mpmrom " << runtime.version << " (" << runtime.git_commit << "): " << runtime.backend << ", "
                << runtime.threads << " threads, " << runtime.device << ", Kokkos " << runtime.kokkos_version << ", "
                << runtime.precision << "\n";
    }
    const auto progress = [quiet](const mpmrom::SimulationProgress& p) { report_progress(p, quiet); };
    if (*simulate) {
      const mpmrom::Scene scene = mpmrom::load_scene(scene_path, overrides);
      if (!quiet) std::cerr << "mpmrom simulate: " << scene.name << " -> " << out_path << "\n";
      mpmrom::simulate(scene, out_path, p2g, progress);
    }
    if (*sweep) {
      // The sweep's time left from the runs simulated so far (runs kept from before take no time).
      const auto sweep_start = std::chrono::steady_clock::now();
      std::size_t simulated = 0;
      mpmrom::sweep(scene_path, sweep_dir, p2g,
                    [&](std::size_t run, std::size_t num_runs, const mpmrom::SweepRun& r, bool reused) {
                      const double elapsed =
                          std::chrono::duration<double>(std::chrono::steady_clock::now() - sweep_start).count();
                      std::string left;
                      // this process's runs left: every world.size()-th run from here
                      const std::size_t mine_left = (num_runs - run + world.size() - 1) / world.size();
                      if (simulated > 0)
                        left = ", " + duration_string(elapsed / double(simulated) * double(mine_left)) + " left";
                      if (!reused) ++simulated;
                      if (!quiet)
                        std::cerr << "mpmrom sweep: run " << run + 1 << "/" << num_runs << " (" << r.file << ", "
                                  << (r.test ? "test" : "train") << (reused ? ", finished before: kept" : "") << left
                                  << ")\n";
                    },
                    progress, sweep_resume, world);
    }
    const auto pipeline_log = [quiet](const std::string& text) {
      if (!quiet) std::cerr << "mpmrom: " << text << "\n";
    };
    if (*train && !target_errors.empty()) {
      if (search_scene.empty()) throw std::invalid_argument("--target-error needs --scene (the sweep's scene file)");
      if (train_inputs.size() != 1) throw std::invalid_argument("--target-error takes one sweep directory");
      mpmrom::PipelineSettings search;
      search.training = training;
      search.target_errors = target_errors;
      for (const auto& text : search_networks) search.networks.push_back(mpmrom::NetworkShape::parse(text));
      const auto decision = mpmrom::search_model(search_scene, train_inputs[0], model_path + ".search", model_path,
                                                 search, pipeline_log);
      if (train_json) std::cout << decision.dump() << "\n";
    } else if (*train) {
      mpmrom::require_writable_output(model_path);
      if (!quiet) std::cerr << "mpmrom train: reading " << train_inputs.size() << " input(s)\n";
      const auto data = mpmrom::load_training_data(train_inputs);
      if (!quiet)
        std::cerr << "mpmrom train: " << data.train.runs.size() << " training runs, " << data.test.runs.size()
                  << " test runs, " << data.train.runs.front().num_points << " points; r = " << training.latent_dim
                  << ", " << training.depth << " layers of " << training.width << ", lambda1 = "
                  << training.lambda_gradient << ", lambda2 = " << training.lambda_velocity << ", "
                  << training.epochs << " epochs\n";
      const std::string checkpoint = model_path + ".ckpt";
      mpmrom::TrainingCallbacks callbacks;
      callbacks.progress = [quiet](const mpmrom::TrainingProgress& p) { report_training(p, quiet); };
      callbacks.message = [quiet](const std::string& text) {
        if (!quiet) std::cerr << "mpmrom train: " << text << "\n";
      };
      if (!quiet && world.size() > 1)
        std::cerr << "mpmrom train: data-parallel over " << world.size() << " processes\n";
      auto model = mpmrom::train_model(data, training, checkpoint, resume, callbacks, world);
      if (!world.is_root()) return 0;
      if (!quiet) std::cerr << "mpmrom train: ranking " << mpmrom::ranked_samples << " sample points greedily\n";
      model.sample_ranking = mpmrom::rank_samples_greedily(model, data, mpmrom::ranked_samples);
      mpmrom::save_model(model_path, model);
      std::error_code ignored;
      std::filesystem::remove(checkpoint, ignored);
      if (train_json) {
        // a benchmark record (SPEC.md) of the training run, with the model's settings and errors
        auto record = mpmrom::benchmark_record("train", model.scene_name);
        record["model"] = model_path;
        record["particles"] = model.num_points();
        record["training_runs"] = data.train.runs.size();
        record["training_snapshots"] = model.num_codes();
        record["test_runs"] = data.test.runs.size();
        record["training_seconds"] = model.errors["training_seconds"];
        if (model.errors.contains("training_samples_per_s"))
          record["training_samples_per_s"] = model.errors["training_samples_per_s"];
        record["settings"] = model.settings;
        record["errors"] = model.errors;
        std::cout << record.dump() << "\n";
      }
      if (!quiet) {
        std::cerr << "mpmrom train: wrote " << model_path << "\n";
        for (const char* split : {"train", "validation_points", "test"}) {
          if (!model.errors.contains(split)) continue;
          const auto& e = model.errors[split];
          std::fprintf(stderr, "  %-18s position %.4f %%  displacement %.3f %%  velocity %.3f %%  F %.4f %%  strain %.3f %%\n",
                       split, 100 * e["position_error"].get<double>(), 100 * e["displacement_error"].get<double>(),
                       100 * e["velocity_error"].get<double>(), 100 * e["F_error"].get<double>(),
                       100 * e["strain_error"].get<double>());
        }
      }
    }
    if (*rollout) {
      mpmrom::require_writable_output(rom_path);
      rom_settings.method = mpmrom::rom_method_from_string(rom_method);
      rom_settings.selection = mpmrom::sample_selection_from_string(rom_selection);
      rom_settings.validate();
      const mpmrom::Model model = mpmrom::load_model(model_path);
      const mpmrom::Scene scene = mpmrom::load_scene(scene_path);
      std::vector<std::string> names;
      const auto cases = rollout_cases(scene, params_path, names);
      mpmrom::TrainingData data;
      if (!rom_data.empty()) data = mpmrom::load_training_data(rom_data);
      const auto samples = mpmrom::select_samples(model, scene, rom_settings, rom_data.empty() ? nullptr : &data);
      const auto reduction = mpmrom::build_hyper_reduction(model, scene, rom_settings, samples);
      if (!quiet)
        std::cerr << "mpmrom rollout: " << cases.size() << " rollout(s)"
                  << (world.size() > 1 ? " over " + std::to_string(world.size()) + " processes" : std::string())
                  << ", method " << rom_method << ", " << reduction.summary().dump() << "\n";
      rollout_checkpoint.path = rom_path + ".ckpt";
      const std::string own_checkpoint =
          mpmrom::rank_checkpoint_path(rollout_checkpoint.path, world.rank(), world.size());
      const auto remove_checkpoint = [&own_checkpoint]() {
        std::error_code ignored;
        std::filesystem::remove(own_checkpoint, ignored);
        std::filesystem::remove(own_checkpoint + ".prev", ignored);
      };
      const auto result = mpmrom::run_rollouts(
          world, model, scene_path, names, cases, rom_settings, reduction,
          [quiet, rollouts = cases.size()](const mpmrom::RomProgress& p) {
            if (quiet || (!every_progress_line() && p.frame % std::max(1, p.frames / 5) != 0)) return;
            const double rate = p.seconds > 0 ? double(p.steps) * double(rollouts) / p.seconds : 0;
            const double left = p.frame > 0 ? p.seconds * (p.frames - p.frame) / p.frame : 0;
            std::fprintf(stderr, "  frame %d/%d  t = %.4f s  %ld steps  %.3g rollout-steps/s  %s left\n", p.frame,
                         p.frames, p.time, p.steps, rate, duration_string(left).c_str());
          },
          rollout_checkpoint);
      if (!world.is_root()) {  // rank 0 writes the batch; the checkpoints go once it is written
        world.barrier();
        remove_checkpoint();
        return 0;
      }
      mpmrom::RomFile file;
      file.result = result;
      file.model_path = std::filesystem::absolute(model_path).string();
      file.model_checksum = mpmrom::model_checksum(model);
      file.scene_name = scene.name;
      file.scene_text = scene.source_text;
      file.settings = rom_settings.to_json();
      file.hyper_reduction = reduction.summary();
      file.samples = reduction.samples;
      file.sets = reduction;
      const double rollout_steps = double(result.steps) * double(cases.size());
      const double simulated = result.times.empty() ? 0.0 : result.times.back() - result.times.front();
      file.timing = {{"steps", result.steps},
                     {"simulated_seconds", simulated},
                     // the cost users compare with the FOM's: wall time per simulated second, per rollout
                     {"rom_seconds_per_simulated_second",
                      simulated > 0 ? result.step_seconds / (simulated * double(cases.size())) : 0.0},
                     {"rollouts", cases.size()},
                     {"setup_seconds", result.setup_seconds},
                     {"step_seconds_total", result.step_seconds},
                     {"rom_step_seconds", result.steps > 0 ? result.step_seconds / result.steps : 0.0},
                     {"rom_rollout_steps_per_s", result.step_seconds > 0 ? rollout_steps / result.step_seconds : 0.0}};
      if (decode_mode != "none") {
        if (decode_mode == "reference") {
          file.decoded_X = model.X;
        } else if (decode_mode == "lattice") {
          if (!(decode_spacing > 0)) throw std::invalid_argument("--decode lattice needs --decode-spacing > 0");
          for (const auto& body : scene.bodies)
            for (const auto& p : mpmrom::lattice_points(body, decode_spacing))
              file.decoded_X.insert(file.decoded_X.end(), p.begin(), p.end());
        } else {
          throw std::invalid_argument("--decode must be none, reference or lattice, not '" + decode_mode + "'");
        }
        const std::size_t frames = result.times.size(), r = std::size_t(result.latent_dim);
        for (std::size_t b = 0; b < cases.size(); ++b) {
          const std::vector<double> xhat(result.xhat.begin() + b * frames * r, result.xhat.begin() + (b + 1) * frames * r);
          const std::vector<double> xhatdot(result.xhatdot.begin() + b * frames * r,
                                            result.xhatdot.begin() + (b + 1) * frames * r);
          const auto fields = mpmrom::decode(model, file.decoded_X, xhat, xhatdot);
          file.decoded_x.insert(file.decoded_x.end(), fields.x.begin(), fields.x.end());
          file.decoded_v.insert(file.decoded_v.end(), fields.v.begin(), fields.v.end());
          file.decoded_F.insert(file.decoded_F.end(), fields.F.begin(), fields.F.end());
        }
      }
      mpmrom::save_rom(rom_path, file);
      world.barrier();
      remove_checkpoint();
      int failed = 0;
      for (std::size_t b = 0; b < cases.size(); ++b) {
        const auto& o = result.outcomes[b];
        if (!o.warning.empty()) std::cerr << "mpmrom rollout: warning: rollout " << b << ": " << o.warning << "\n";
        if (!o.message.empty()) {
          ++failed;
          std::cerr << "mpmrom rollout: rollout " << b << " " << o.message << "\n";
        }
      }
      if (!quiet) {
        double worst = 0;
        long regularized = 0, inversion = 0;
        for (const auto& o : result.outcomes) {
          worst = std::max(worst, o.max_condition);
          regularized += o.regularized_steps;
          inversion += o.inversion_failures;
        }
        std::fprintf(stderr,
                     "mpmrom rollout: wrote %s: %zu rollouts x %ld steps in %.3f s (%.3g s per step, %.3g "
                     "rollout-steps/s); largest normal-equation condition estimate %.3g, %ld regularised steps, "
                     "%ld failed inversions\n",
                     rom_path.c_str(), cases.size(), result.steps, result.step_seconds,
                     file.timing["rom_step_seconds"].get<double>(), file.timing["rom_rollout_steps_per_s"].get<double>(),
                     worst, regularized, inversion);
      }
      if (rollout_json) {
        auto record = mpmrom::benchmark_record("rom_rollout", scene.name);
        record["particles"] = model.num_points();
        record["model"] = model_path;
        record["latent_dim"] = model.latent_dim;
        record["settings"] = file.settings;
        record["hyper_reduction"] = file.hyper_reduction;
        for (const auto& [key, value] : file.timing.items()) record[key] = value;
        std::cout << record.dump() << "\n";
      }
      if (failed > 0) return 3;
    }
    if (*stability) {
      stability_settings.selection = mpmrom::sample_selection_from_string(stability_selection);
      std::size_t done = 0;
      const auto cases = mpmrom::run_stability(stability_settings, [&](const mpmrom::StabilityCase& c) {
        if (quiet) return;
        std::fprintf(stderr, "mpmrom stability: %3zu %-9s %-18s cfl %-4g h %-3gx d %-5g load %-3g %-8s %-12s %s%.3g %% (%.2f s)%s%s\n",
                     ++done, c.study.c_str(), c.config.c_str(), c.cfl, c.horizon, c.extrapolation, c.load_factor,
                     c.material.empty() ? "scene" : c.material.c_str(), c.status.c_str(), "", 100 * c.position_error,
                     c.seconds, c.cause.empty() ? "" : ": ", c.cause.substr(0, 90).c_str());
      });
      if (!quiet)
        std::fprintf(stderr, "mpmrom stability: %zu cases; wrote %s/stability.md, stability.json and the charts\n",
                     cases.size(), stability_settings.out_dir.c_str());
    }
    if (*pipeline) {
      for (const auto& text : pipeline_networks) pipeline_settings.networks.push_back(mpmrom::NetworkShape::parse(text));
      if (!pipeline_methods.empty()) {
        pipeline_settings.methods.clear();
        for (const auto& m : pipeline_methods) pipeline_settings.methods.push_back(mpmrom::rom_method_from_string(m));
      }
      pipeline_settings.command = "mpmrom";
      for (int a = 1; a < argc; ++a) pipeline_settings.command += std::string(" ") + argv[a];
      mpmrom::run_pipeline(pipeline_settings, pipeline_log);
    }
    if (*upgrade) {
      int failed = 0;
      for (const auto& file : upgrade_files) {
        try {
          const std::string done = mpmrom::upgrade_file(file);
          if (!quiet) std::cerr << "mpmrom upgrade: " << done << "\n";
        } catch (const std::exception& e) {
          ++failed;
          std::cerr << "mpmrom: error: " << e.what() << "\n";
        }
      }
      if (failed > 0) return 1;
    }
    if (*evaluate) {
      const mpmrom::RomFile rom = mpmrom::load_rom(rom_path);
      const std::string path = evaluate_model.empty() ? rom.model_path : evaluate_model;
      const mpmrom::Model model = mpmrom::load_model(path);
      if (mpmrom::model_checksum(model) != rom.model_checksum)
        throw std::runtime_error(path + ": not the model " + rom_path + " was run with (its weights differ)");
      const auto data = mpmrom::load_runs(references);
      const auto errors = mpmrom::evaluate_rom(rom, model, data);
      if (evaluate_json) std::cout << errors.dump() << "\n";
      if (!quiet) {
        std::cerr << "mpmrom evaluate: " << errors["matched"] << " of " << errors["rollouts"]
                  << " rollouts matched a reference run\n";
        print_metrics("all", errors);
        print_metrics("train", errors["train"]);
        print_metrics("test", errors["test"]);
      }
    }
    if (*bench_fom) {
      const mpmrom::Scene scene = mpmrom::load_scene(scene_path, overrides);
      const auto result = mpmrom::bench_fom(scene, p2g, tiling, particle_order, bench_steps, bench_warmup);
      auto record = mpmrom::benchmark_record("fom_step", scene.name);
      record["p2g"] = p2g_name(p2g);
      record["particle_order"] = particle_order == mpmrom::ParticleOrder::Bricks ? "bricks" : "sampling";
      if (p2g == mpmrom::P2GStrategy::Tiled)
        record["p2g_tiling"] = {{"team_size", tiling.team_size},
                                {"particles_per_team", tiling.particles_per_team},
                                {"max_tile_nodes", tiling.max_tile_nodes}};
      record["particles"] = result.particles;
      record["grid_nodes"] = result.grid_nodes;
      record["steps"] = result.steps;
      record["dt_s"] = result.dt;
      record["fom_step_seconds"] = result.seconds / result.steps;
      record["fom_particle_steps_per_s"] = double(result.particles) * result.steps / result.seconds;
      record["particle_bytes_per_step"] = result.particle_bytes;
      record["grid_bytes_per_step"] = result.grid_bytes;
      record["effective_bandwidth_bytes_per_s"] =
          (result.particle_bytes + result.grid_bytes) * result.steps / result.seconds;
      if (bench_json)
        std::cout << record.dump() << "\n";
      else
        std::cout << record.dump(2) << "\n";
    }
    if (*bench_nn) {
      const auto result = mpmrom::bench_nn(nn_bench);
      auto record = mpmrom::benchmark_record("nn_kernels", "random");
      record["latent_dim"] = nn_bench.latent_dim;
      record["width"] = nn_bench.width;
      record["depth"] = nn_bench.depth;
      record["evaluation_batch"] = result.evaluations;
      record["flops_per_evaluation"] = result.flops_per_evaluation;
      record["nn_jacobian_evaluations_per_s"] = result.evaluations / result.evaluation_seconds;
      record["nn_jacobian_gflops_per_s"] =
          result.evaluations * result.flops_per_evaluation / result.evaluation_seconds * 1e-9;
      record["training_batch_samples"] = result.training_samples;
      record["flops_per_training_sample"] = result.flops_per_training_sample;
      record["training_samples_per_s"] = result.training_samples / result.training_step_seconds;
      record["training_gflops_per_s"] =
          result.training_samples * result.flops_per_training_sample / result.training_step_seconds * 1e-9;
      std::cout << (bench_json ? record.dump() : record.dump(2)) << "\n";
    }
    if (*info) {
      const auto runtime = mpmrom::runtime_info();
      if (info_json) {
        std::cout << to_json(runtime).dump() << "\n";
      } else {
        std::cout << "mpmrom " << runtime.version << " (" << runtime.git_commit << ")\n"
                  << "  backend:   " << runtime.backend << " (" << runtime.threads << " threads)\n"
                  << "  device:    " << runtime.device << "\n"
                  << "  kokkos:    " << runtime.kokkos_version << "\n"
                  << "  precision: " << runtime.precision << "\n";
      }
    }
  } catch (const mpmrom::SimulationFailure& e) {
    std::cerr << "mpmrom: the simulation failed (" << to_string(e.cause()) << ") at " << e.what() << "\n";
    return fail(3);
  } catch (const std::bad_alloc& e) {
    std::cerr << out_of_memory(e.what());
    return fail(1);
  } catch (const std::exception& e) {
    // Kokkos reports a failed View allocation as a runtime error of several lines.
    const std::string what = e.what();
    std::cerr << (what.rfind("Kokkos failed to allocate", 0) == 0 ? out_of_memory(what)
                                                                   : "mpmrom: error: " + what + "\n");
    return fail(1);
  }
  return 0;
}
