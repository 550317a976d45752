// mpmrom bench fom|rom|nn: benchmark records of the full-order step, the reduced step and the network kernels
// (perf/README.md).
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench/bench.hpp"
#include "command.hpp"
#include "common.hpp"

namespace mpmrom::cli {
namespace {

struct Options {
  long bench_steps = 20, bench_warmup = 3;
  bool bench_json = false;
  std::string scene_path;
  std::vector<std::string> overrides;
  P2GStrategy p2g = default_p2g_strategy();
  P2GTiling tiling = default_p2g_tiling<FomSolver::ExecutionSpace>();
  ParticleOrder particle_order = default_particle_order();
  NnBenchmarkSettings nn_bench;
  std::string model_path, rom_method = "galerkin", integrator = "auto";
  mpmrom::RomSettings rom_settings;
  int rom_samples = 60, rollouts = 2, frames = 3, warmup = 1;
};

int run_fom(const Options& o) {
  const mpmrom::Scene scene = mpmrom::load_scene(o.scene_path, o.overrides);
  const auto result = mpmrom::bench_fom(scene, o.p2g, o.tiling, o.particle_order, o.bench_steps, o.bench_warmup);
  auto record = mpmrom::benchmark_record("fom_step", scene.name);
  record["p2g"] = p2g_name(o.p2g);
  record["particle_order"] = o.particle_order == mpmrom::ParticleOrder::Bricks ? "bricks" : "sampling";
  if (o.p2g == mpmrom::P2GStrategy::Tiled)
    record["p2g_tiling"] = {{"team_size", o.tiling.team_size},
                            {"particles_per_team", o.tiling.particles_per_team},
                            {"max_tile_nodes", o.tiling.max_tile_nodes}};
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
  if (o.bench_json)
    std::cout << record.dump() << "\n";
  else
    std::cout << record.dump(2) << "\n";
  return 0;
}

int run_rom(const Options& o) {
  const mpmrom::Scene scene = mpmrom::load_scene(o.scene_path, o.overrides);
  const mpmrom::RomMethod method = mpmrom::rom_method_from_string(o.rom_method);
  mpmrom::RomSettings settings = mpmrom::rom_defaults(method);
  settings.samples = o.rom_samples;
  settings.seed = o.rom_settings.seed;
  settings.cfl = o.rom_settings.cfl;
  if (o.integrator != "auto") settings.integrator = mpmrom::time_integrator_from_string(o.integrator);
  const auto result =
      mpmrom::bench_rom(mpmrom::load_model(o.model_path), scene, settings, o.rollouts, o.frames, o.warmup);
  auto record = mpmrom::benchmark_record("rom_step", scene.name);
  record["model"] = o.model_path;
  record["method"] = o.rom_method;
  record["settings"] = result.settings.to_json();  // random samples weighted by their masses, no step bound
  record["particles"] = result.particles;
  record["model_points"] = result.model_points;
  record["samples"] = result.samples;
  record["rollouts"] = result.rollouts;
  record["frames"] = result.frames;
  record["steps"] = result.steps;
  record["rom_step_seconds"] = result.seconds / double(result.steps);
  record["rom_rollout_steps_per_s"] = double(result.steps) * result.rollouts / result.seconds;
  record["setup_seconds"] = result.setup_seconds;
  record["stopped_rollouts"] = result.stopped_rollouts;
  std::cout << (o.bench_json ? record.dump() : record.dump(2)) << "\n";
  return 0;
}

int run_nn(const Options& o) {
  const auto result = mpmrom::bench_nn(o.nn_bench);
  auto record = mpmrom::benchmark_record("nn_kernels", "random");
  record["latent_dim"] = o.nn_bench.latent_dim;
  record["width"] = o.nn_bench.width;
  record["depth"] = o.nn_bench.depth;
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
  std::cout << (o.bench_json ? record.dump() : record.dump(2)) << "\n";
  return 0;
}

}  // namespace

void add_bench(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand("bench", "Time the solvers; --json prints one benchmark record on stdout");
  command->require_subcommand(1);
  auto* bench_fom_command = command->add_subcommand("fom", "Full-order MPM steps per second on a scene");
  add_input(bench_fom_command, "scene", o->scene_path, "Scene file (TOML)");
  bench_fom_command->add_option("--set", o->overrides, "Override: parameter=value, or a scene entry like grid.dx=0.02");
  bench_fom_command->add_option("--steps", o->bench_steps, "Timed steps")->check(CLI::PositiveNumber);
  bench_fom_command->add_option("--warmup", o->bench_warmup, "Untimed steps first")->check(CLI::NonNegativeNumber);
  bench_fom_command->add_option("--p2g", o->p2g, kP2GHelp)
      ->transform(CLI::CheckedTransformer(kP2GStrategies, CLI::ignore_case));
  add_defaulted(bench_fom_command, "--team-size", o->tiling.team_size, "Tiled P2G: threads per team")
      ->check(CLI::PositiveNumber);
  add_defaulted(bench_fom_command, "--particles-per-team", o->tiling.particles_per_team,
                "Tiled P2G: consecutive particles per team")
      ->check(CLI::PositiveNumber);
  add_defaulted(bench_fom_command, "--tile-nodes", o->tiling.max_tile_nodes,
                "Tiled P2G: largest tile (nodes) a team keeps in scratch")
      ->check(CLI::Range(27, 1 << 20));
  const std::map<std::string, mpmrom::ParticleOrder> particle_orders{{"sampling", mpmrom::ParticleOrder::Sampling},
                                                                     {"bricks", mpmrom::ParticleOrder::Bricks}};
  bench_fom_command
      ->add_option("--order", o->particle_order, "How particles are stored: sampling (the scene's order) or bricks")
      ->transform(CLI::CheckedTransformer(particle_orders, CLI::ignore_case));
  bench_fom_command->add_flag("--json", o->bench_json, "One JSON record on stdout");
  bench_fom_command->footer("Example: mpmrom bench fom scenes/cylinder_1e6.toml --p2g scatter --json");

  auto* bench_rom_command = command->add_subcommand(
      "rom",
      "The reduced model's step on a scene, the model decoded at the scene's own points (its cost, not its accuracy)");
  add_input(bench_rom_command, "model", o->model_path, "Model file (HDF5), trained on this scene's body");
  add_input(bench_rom_command, "scene", o->scene_path, "Scene file (TOML): the same body at any lattice spacing");
  add_defaulted(bench_rom_command, "--method", o->rom_method, "point, node or galerkin");
  add_defaulted(bench_rom_command, "--samples", o->rom_samples, "Random samples, weighted by their masses")
      ->check(CLI::PositiveNumber);
  add_defaulted(bench_rom_command, "--seed", o->rom_settings.seed, "Seed of the random samples");
  add_defaulted(bench_rom_command, "--cfl", o->rom_settings.cfl,
                "Time step as a fraction of the CFL limit (0: the scene's; no reduced-dynamics bound here)")
      ->check(CLI::NonNegativeNumber);
  add_defaulted(bench_rom_command, "--integrator", o->integrator, "With --method galerkin: euler, leapfrog or auto");
  add_defaulted(bench_rom_command, "--rollouts", o->rollouts, "Rollouts in the batch (the scene's parameters each)")
      ->check(CLI::PositiveNumber);
  add_defaulted(bench_rom_command, "--frames", o->frames, "Timed output intervals")->check(CLI::PositiveNumber);
  add_defaulted(bench_rom_command, "--warmup", o->warmup, "Untimed output intervals first")
      ->check(CLI::NonNegativeNumber);
  bench_rom_command->add_flag("--json", o->bench_json, "One JSON record on stdout");
  bench_rom_command->footer("Example: mpmrom bench rom model_1e5.h5 scenes/cylinder_1e7.toml --samples 60 --json");

  auto* bench_nn_command =
      command->add_subcommand("nn", "Network kernels: forward-with-Jacobians evaluations/s, training samples/s");
  add_network_shape(bench_nn_command, o->nn_bench.latent_dim, o->nn_bench.width, o->nn_bench.depth);
  add_defaulted(bench_nn_command, "--points", o->nn_bench.points, "Points per evaluation batch");
  add_defaulted(bench_nn_command, "--codes", o->nn_bench.codes, "Latent codes per evaluation batch (rollouts)");
  add_defaulted(bench_nn_command, "--batch-snapshots", o->nn_bench.batch_snapshots, "Training minibatch: snapshots");
  add_defaulted(bench_nn_command, "--points-per-snapshot", o->nn_bench.points_per_snapshot,
                "Training minibatch: points each");
  bench_nn_command->add_option("--repeats", o->nn_bench.repeats, "Timed repetitions")->check(CLI::PositiveNumber);
  bench_nn_command->add_flag("--json", o->bench_json, "One JSON record on stdout");
  bench_nn_command->footer("Example: mpmrom bench nn --codes 1024 --json");
  commands.push_back({command, nullptr, [o, bench_fom_command, bench_rom_command](const Context&) {
                        if (bench_fom_command->parsed()) return run_fom(*o);
                        return bench_rom_command->parsed() ? run_rom(*o) : run_nn(*o);
                      }});
}

}  // namespace mpmrom::cli
