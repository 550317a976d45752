// mpmrom rollout: a batch of reduced rollouts -> ROM.h5 (docs/rom.md).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "core/benchmark_record.hpp"
#include "core/timing.hpp"
#include "io/atomic_file.hpp"
#include "mpmrom/model.hpp"
#include "rom/rom_file.hpp"
#include "scene/sampling.hpp"
#include "mpmrom/training_data.hpp"

#include "command.hpp"
#include "common.hpp"

namespace mpmrom::cli {
namespace {

struct Options {
  std::string model_path, scene_path;
  RomSettings rom_settings;
  // "auto": the method's default (rom_defaults).
  std::string rom_method = "point", rom_selection = "auto", rom_projection = "velocity", rom_weights = "auto",
              cubature_snapshots = "auto", cubature_target = "auto", galerkin_strain = "auto", integrator = "auto",
              params_path, rom_path, decode_mode = "none", reduction_path;
  std::vector<std::string> rom_data;
  std::vector<double> selection_sensitivities;  // empty: the method's default
  double decode_spacing = 0;
  bool rollout_json = false;
  RolloutCheckpoint rollout_checkpoint;
};

// The rollouts' timings as the ROM file and the benchmark record carry them.
nlohmann::json rollout_timing(const mpmrom::RomResult& result, std::size_t rollouts) {
  const double rollout_steps = double(result.steps) * double(rollouts);
  const double simulated = result.times.empty() ? 0.0 : result.times.back() - result.times.front();
  return {
      {"steps", result.steps},
      {"simulated_seconds", simulated},
      // the cost users compare with the FOM's: wall time per simulated second, per rollout
      {"rom_seconds_per_simulated_second", simulated > 0 ? result.step_seconds / (simulated * double(rollouts)) : 0.0},
      {"rollouts", rollouts},
      {"setup_seconds", result.setup_seconds},
      {"step_seconds_total", result.step_seconds},
      {"rom_step_seconds", result.steps > 0 ? result.step_seconds / result.steps : 0.0},
      {"rom_rollout_steps_per_s", result.step_seconds > 0 ? rollout_steps / result.step_seconds : 0.0}};
}

// The decoded fields --decode asks for, at every frame of every rollout.
void decode_rollouts(const Options& o, const mpmrom::Model& model, const mpmrom::Scene& scene, mpmrom::RomFile& file) {
  if (o.decode_mode == "reference") {
    file.decoded_X = model.X;
  } else if (o.decode_mode == "lattice") {
    if (!(o.decode_spacing > 0)) throw std::invalid_argument("--decode lattice needs --decode-spacing > 0");
    for (const auto& body : scene.bodies)
      for (const auto& p : mpmrom::lattice_points(body, o.decode_spacing))
        file.decoded_X.insert(file.decoded_X.end(), p.begin(), p.end());
  } else {
    throw std::invalid_argument("--decode must be none, reference or lattice, not '" + o.decode_mode + "'");
  }
  const std::size_t frames = file.result.times.size(), r = std::size_t(file.result.latent_dim);
  for (std::size_t b = 0; b < file.result.outcomes.size(); ++b) {
    const std::vector<double> xhat(file.result.xhat.begin() + b * frames * r,
                                   file.result.xhat.begin() + (b + 1) * frames * r);
    const std::vector<double> xhatdot(file.result.xhatdot.begin() + b * frames * r,
                                      file.result.xhatdot.begin() + (b + 1) * frames * r);
    const auto fields = mpmrom::decode(model, file.decoded_X, xhat, xhatdot);
    file.decoded_x.insert(file.decoded_x.end(), fields.x.begin(), fields.x.end());
    file.decoded_v.insert(file.decoded_v.end(), fields.v.begin(), fields.v.end());
    file.decoded_F.insert(file.decoded_F.end(), fields.F.begin(), fields.F.end());
  }
}

// What happened to a batch, summed over its rollouts: the summary line and the --json record both report it.
struct OutcomeTotals {
  int stopped = 0;
  double worst_condition = 0;
  long regularized = 0, inversion_failures = 0;
};

OutcomeTotals outcome_totals(const mpmrom::RomResult& result) {
  OutcomeTotals totals;
  for (const auto& o : result.outcomes) {
    totals.stopped += o.message.empty() ? 0 : 1;
    totals.worst_condition = std::max(totals.worst_condition, o.max_condition);
    totals.regularized += o.regularized_steps;
    totals.inversion_failures += o.inversion_failures;
  }
  return totals;
}

// Each stopped rollout and warning on a line of its own, then (unless quiet) the batch's summary.
void report_outcomes(const mpmrom::RomResult& result, bool quiet, const std::string& rom_path,
                     const nlohmann::json& timing) {
  for (std::size_t b = 0; b < result.outcomes.size(); ++b) {
    const auto& outcome = result.outcomes[b];
    if (!outcome.warning.empty())
      std::cerr << "mpmrom rollout: warning: rollout " << b << ": " << outcome.warning << "\n";
    if (!outcome.message.empty()) std::cerr << "mpmrom rollout: rollout " << b << " " << outcome.message << "\n";
  }
  if (quiet) return;
  const OutcomeTotals totals = outcome_totals(result);
  print_stderr(
      "mpmrom rollout: wrote %s: %zu rollouts x %ld steps in %.3f s (%.3g s per step, %.3g "
      "rollout-steps/s); largest normal-equation condition estimate %.3g, %ld regularised steps, "
      "%ld failed inversions\n",
      rom_path.c_str(), result.outcomes.size(), result.steps, result.step_seconds,
      timing["rom_step_seconds"].get<double>(), timing["rom_rollout_steps_per_s"].get<double>(), totals.worst_condition,
      totals.regularized, totals.inversion_failures);
}

// Progress lines of a batch: every frame, or five a run (set_verbosity).
std::function<void(const mpmrom::RomProgress&)> rollout_progress(bool quiet, std::size_t rollouts) {
  return [quiet, rollouts](const mpmrom::RomProgress& p) {
    check_interruption();
    if (quiet || (!every_progress_line() && p.frame % std::max(1, p.frames / 5) != 0)) return;
    const double rate = p.seconds > 0 ? double(p.steps) * double(rollouts) / p.seconds : 0;
    const double left = p.frame > 0 ? p.seconds * (p.frames - p.frame) / p.frame : 0;
    print_stderr("  frame %d/%d  t = %.4f s  %ld steps  %.3g rollout-steps/s  %s left\n", p.frame, p.frames, p.time,
                 p.steps, rate, duration_string(left).c_str());
  };
}

// The rollout's settings from the flags' names, "auto" as the method's default (rom_defaults); throws
// std::invalid_argument on a bad name or combination.
void resolve_settings(Options& o) {
  o.rom_settings.method = mpmrom::rom_method_from_string(o.rom_method);
  const mpmrom::RomSettings defaults = mpmrom::rom_defaults(o.rom_settings.method);
  const auto pick = [](const std::string& name, auto method_default, auto parse) {
    return name == "auto" ? method_default : parse(name);
  };
  o.rom_settings.selection = pick(o.rom_selection, defaults.selection, mpmrom::sample_selection_from_string);
  o.rom_settings.selection_sensitivities =
      o.selection_sensitivities.empty() ? defaults.selection_sensitivities : o.selection_sensitivities;
  o.rom_settings.projection = mpmrom::projection_scheme_from_string(o.rom_projection);
  o.rom_settings.weighting = mpmrom::sample_weighting_from_string(o.rom_weights);
  o.rom_settings.snapshot_source =
      pick(o.cubature_snapshots, defaults.snapshot_source, mpmrom::snapshot_source_from_string);
  o.rom_settings.cubature_target =
      pick(o.cubature_target, defaults.cubature_target, mpmrom::cubature_target_from_string);
  o.rom_settings.galerkin_strain =
      pick(o.galerkin_strain, defaults.galerkin_strain, mpmrom::galerkin_strain_from_string);
  // The leapfrog does not take the transfer's gather: auto falls back to symplectic Euler there.
  const auto integrator =
      o.rom_settings.galerkin_transfer ? mpmrom::TimeIntegrator::SymplecticEuler : defaults.integrator;
  o.rom_settings.integrator = pick(o.integrator, integrator, mpmrom::time_integrator_from_string);
  o.rom_settings.validate();
}

// o is a copy: the run completes its settings.
int run(Options o, const Context& context) {
  const bool quiet = context.quiet;
  const auto& world = context.world;
  mpmrom::require_writable_output(o.rom_path);
  resolve_settings(o);
  const mpmrom::Model model = mpmrom::load_model(o.model_path);
  const mpmrom::Scene scene = mpmrom::load_scene(o.scene_path);
  std::vector<std::string> names;
  const auto cases = rollout_cases(scene, o.params_path, names);
  mpmrom::TrainingData data;
  if (!o.rom_data.empty()) data = mpmrom::load_training_data(o.rom_data);
  const auto offline_start = mpmrom::SteadyClock::now();
  const auto reduction =
      o.reduction_path.empty()
          ? mpmrom::prepare_hyper_reduction(model, scene, o.rom_settings, o.rom_data.empty() ? nullptr : &data,
                                            [quiet](const std::string& line) {
                                              if (!quiet) std::cerr << "mpmrom rollout: " << line << "\n";
                                            })
          : mpmrom::reduction_from_rom(mpmrom::load_rom(o.reduction_path), o.reduction_path, model, scene,
                                       o.rom_settings);
  const double offline_seconds = mpmrom::seconds_since(offline_start);
  if (!quiet)
    std::cerr << "mpmrom rollout: " << cases.size() << " rollout(s)"
              << (world.size() > 1 ? " over " + std::to_string(world.size()) + " processes" : std::string())
              << ", method " << o.rom_method << ", " << reduction.summary().dump() << "\n";
  o.rollout_checkpoint.path = o.rom_path + ".ckpt";
  const std::string own_checkpoint =
      mpmrom::rank_checkpoint_path(o.rollout_checkpoint.path, world.rank(), world.size());
  const auto remove_checkpoint = [&own_checkpoint]() {
    std::error_code ignored;
    std::filesystem::remove(own_checkpoint, ignored);
    std::filesystem::remove(own_checkpoint + ".prev", ignored);
  };
  const auto result = mpmrom::run_rollouts(world, model, o.scene_path, names, cases, o.rom_settings, reduction,
                                           rollout_progress(quiet, cases.size()), o.rollout_checkpoint);
  if (!world.is_root()) {  // rank 0 writes the batch; the checkpoints go once it is written
    world.barrier();
    remove_checkpoint();
    return 0;
  }
  mpmrom::RomFile file;
  file.result = result;
  file.model_path = std::filesystem::absolute(o.model_path).string();
  file.model_checksum = mpmrom::model_checksum(model);
  file.scene_name = scene.name;
  file.scene_text = scene.source_text;
  file.settings = o.rom_settings.to_json();
  file.hyper_reduction = reduction.summary();
  file.hyper_reduction["evaluated_points"] = result.evaluated_points;
  if (!o.reduction_path.empty())  // where its sets come from: the fits' misfits and cost are that file's
    file.hyper_reduction["reused_from"] = std::filesystem::absolute(o.reduction_path).string();
  file.samples = reduction.samples;
  file.sets = reduction;
  file.timing = rollout_timing(result, cases.size());
  // the samples' selection and weights (the offline fits), apart from the stepper's set-up
  file.timing["hyper_reduction_seconds"] = offline_seconds;
  if (o.decode_mode != "none") decode_rollouts(o, model, scene, file);
  mpmrom::save_rom(o.rom_path, file);
  world.barrier();
  remove_checkpoint();
  report_outcomes(result, quiet, o.rom_path, file.timing);
  const OutcomeTotals totals = outcome_totals(result);
  if (o.rollout_json) {
    auto record = mpmrom::benchmark_record("rom_rollout", scene.name);
    record["particles"] = model.num_points();
    record["model"] = o.model_path;
    record["latent_dim"] = model.latent_dim;
    record["settings"] = file.settings;
    record["hyper_reduction"] = file.hyper_reduction;
    for (const auto& [key, value] : file.timing.items()) record[key] = value;
    record["rollouts"] = result.outcomes.size();
    record["stopped_rollouts"] = totals.stopped;
    record["max_condition"] = totals.worst_condition;
    record["regularized_steps"] = totals.regularized;
    std::cout << record.dump() << "\n";
  }
  if (totals.stopped > 0) return 3;
  return 0;
}

}  // namespace

void add_rollout(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand("rollout", "Run the reduced model: one or many rollouts in one batch -> ROM.h5");
  add_input(command, "model", o->model_path, "Model file (from mpmrom train)");
  add_input(command, "scene", o->scene_path, "Scene file (TOML) the model was trained on");
  command->add_option("--out", o->rom_path, "ROM file to write (HDF5)")->required();
  add_defaulted(command, "--method", o->rom_method,
                "point (Algorithm 1, material-point-centric), node (Algorithm 2) or galerkin (the reduced equations of "
                "motion by cubature over the samples, no grid)");
  add_defaulted(command, "--samples", o->rom_settings.samples,
                "Sample material points for the projection; 0: all points");
  add_defaulted(command, "--selection", o->rom_selection,
                "Sample selection: greedy-projection (the samples whose projection of the grid step best matches every "
                "point's; the model's stored set, or fitted to the reduced model's motion), greedy (from the model's "
                "stored ranking, or refitted to --data), cubature (ECSW's active set), region or random; auto: "
                "greedy-projection, cubature with --method galerkin");
  command
      ->add_option("--selection-sensitivities", o->selection_sensitivities,
                   "With --selection greedy-projection: a trial set for each weight of the samples' response to the "
                   "latent state against their increments' own (0: the increments alone); of several, the set whose "
                   "rollouts over the training runs stay closest to the model's codes (default: 0 0.1 0.3 1; 0 with "
                   "--method node, whose trial rollouts would take tens of minutes)")
      ->expected(1, 8);
  command
      ->add_option("--reduction", o->reduction_path,
                   "An earlier ROM.h5 of this model, scene and settings whose samples, weights and sets to reuse "
                   "instead of fitting them again (they may differ in --end-time, --energy-growth and a --cfl the "
                   "fits do not see)")
      ->check(CLI::ExistingFile);
  command->add_option("--data", o->rom_data,
                      "Full-order training runs (sweep directory) to refit --selection greedy to");
  add_defaulted(command, "--seed", o->rom_settings.seed, "Seed of --selection random");
  command->add_option("--params", o->params_path, "Parameter file (design.csv form); default: the scene's design")
      ->check(CLI::ExistingFile);
  add_defaulted(
      command, "--cfl", o->rom_settings.cfl,
      "Time step as a fraction of the CFL limit, up to 10, 100 with --method galerkin, whose step its reduced "
      "dynamics' highest frequency also bounds (0: the scene's; above 1 the FOM would be unstable)");
  add_defaulted(command, "--end-time", o->rom_settings.end_time,
                "Horizon (s), rounded to whole output intervals of the scene (0: the scene's end time)");
  add_defaulted(command, "--margin", o->rom_settings.envelope_margin, "Cells of slack around the training motion");
  add_defaulted(command, "--quadrature", o->rom_settings.quadrature_order,
                "Algorithm 2: Gauss points per axis per cell");
  add_defaulted(command, "--newton-tolerance", o->rom_settings.newton_tolerance,
                "Algorithm 2: inversion tolerance, cells");
  add_defaulted(command, "--projection-iterations", o->rom_settings.projection_iterations,
                "Re-projections with dg/dxhat at the trial next state (0: the paper's, at xhat(t_n))");
  add_defaulted(command, "--projection", o->rom_projection,
                "velocity (fit the samples' velocities and integrate) or position (also Gauss-Newton onto the "
                "samples' updated positions in the re-projections)");
  add_defaulted(command, "--weights", o->rom_weights,
                "The samples' weights in the projection: mass, cubature (fitted to --cubature-snapshots), or auto "
                "(the weights greedy-projection and cubature fit with their samples, the masses otherwise)");
  add_defaulted(command, "--cubature-snapshots", o->cubature_snapshots,
                "What the cubature and greedy-projection fit: reduced (the all-point reduced model's projections over "
                "the scene's "
                "training design), states (one all-point sub-step from the model's training states) or full (the "
                "--data full-order runs); auto: reduced, states with --method galerkin");
  add_defaulted(command, "--cubature-candidates", o->rom_settings.cubature_candidates,
                "On a body of more points: the offline fits' candidates, spread evenly over it (set-up memory and "
                "time grow with their square)");
  add_defaulted(command, "--cubature-runs", o->rom_settings.cubature_runs,
                "The training runs the offline fits probe or roll out, spread over the scene's design");
  add_defaulted(
      command, "--cubature-frames", o->rom_settings.cubature_frames,
      "With --cubature-snapshots states: the inner output frames of each run probed, spread over its horizon");
  add_defaulted(command, "--cubature-target", o->cubature_target,
                "With --method galerkin: what its cubature weights reproduce, its own all-point reduced force (own) "
                "or the grid step's, Algorithm 1 with every point (grid); auto: grid with --method galerkin");
  add_defaulted(command, "--galerkin-strain", o->galerkin_strain,
                "With --method galerkin: the deformation gradient its energy is taken at, the manifold's own at each "
                "sample (continuum) or MPM's, from the displacements of the grid nodes around it (grid); auto: grid");
  command->add_flag("--galerkin-transfer", o->rom_settings.galerkin_transfer,
                    "With --galerkin-strain grid: carry each sample's momentum through its grid nodes as MPM's "
                    "transfer does, instead of along the manifold's tangent");
  command->add_flag("--galerkin-node-average", o->rom_settings.galerkin_node_average,
                    "With --galerkin-strain grid: the stress and the loads work against each stencil node's dg/dxhat "
                    "at the mass centroid of the material it receives (as G2P and the projection average the grid's "
                    "change), instead of at the node");
  add_defaulted(
      command, "--integrator", o->integrator,
      "With --method galerkin: its time integrator, symplectic Euler (euler: the force at the step's start) "
      "or leapfrog (the force half a step on: second order for the same one force a step); auto: leapfrog, euler "
      "with --galerkin-transfer");
  add_defaulted(command, "--rate-damping", o->rom_settings.rate_damping,
                "Tikhonov weight toward the previous latent rate, relative to the normal matrix's mean eigenvalue");
  command->add_option("--max-condition", o->rom_settings.max_condition,
                      "Condition estimate of the normal equations above which they are regularised (0: 0.01/epsilon)");
  command->add_flag("!--no-regularize", o->rom_settings.regularize,
                    "Stop a rollout at an ill-conditioned projection instead of regularising it");
  command->add_flag("!--no-inversion-fallback", o->rom_settings.inversion_fallback,
                    "Algorithm 2: drop a quadrature point whose inversion failed, without retrying");
  add_defaulted(command, "--max-failed-inversions", o->rom_settings.max_failed_inversions,
                "Algorithm 2: stop when more than this fraction of the quadrature points fails in a step");
  add_defaulted(command, "--energy-growth", o->rom_settings.energy_growth,
                "Stop when |dxhat/dt| exceeds this times the fastest training motion (0: no check)");
  add_defaulted(command, "--decode", o->decode_mode,
                "Decoded fields to store: none, reference (the model's points) or lattice (--decode-spacing)");
  command->add_option("--decode-spacing", o->decode_spacing, "Lattice spacing (m) of --decode lattice");
  command->add_flag("--json", o->rollout_json, "Print a benchmark record (timings, hyper-reduction) on stdout");
  add_defaulted(command, "--checkpoint-seconds", o->rollout_checkpoint.seconds,
                "Seconds between checkpoints (ROM.h5.ckpt, at output frames)")
      ->check(CLI::NonNegativeNumber);
  command->add_flag("--resume", o->rollout_checkpoint.resume,
                    "Continue from ROM.h5.ckpt, left by a run that was stopped");
  command->footer("Example: mpmrom rollout poke_model.h5 scenes/poke_cylinder.toml --out rom.h5 --method node");
  commands.push_back({command, [] { return true; }, [o](const Context& context) { return run(*o, context); }});
}

}  // namespace mpmrom::cli
