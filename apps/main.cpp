// mpmrom: the command-line front end. Parsing and printing only; the work is done by the library.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <map>
#include <unistd.h>

#include "bench.hpp"
#include "mpmrom_config.hpp"
#include "runtime.hpp"
#include "simulate.hpp"
#include "trainer.hpp"

namespace {

nlohmann::json to_json(const mpmrom::RuntimeInfo& info) {
  return {{"version", info.version},       {"git_commit", info.git_commit},
          {"backend", info.backend},       {"threads", info.threads},
          {"device", info.device},         {"kokkos_version", info.kokkos_version},
          {"precision", info.precision}};
}

const std::map<std::string, mpmrom::P2GStrategy> kP2GStrategies{{"atomic", mpmrom::P2GStrategy::Atomic},
                                                                   {"scatter", mpmrom::P2GStrategy::ScatterView}};

// One progress line per tenth of a run (every frame on a terminal), with the rate and the time left.
void report_progress(const mpmrom::SimulationProgress& p, bool quiet) {
  if (quiet) return;
  const bool terminal = isatty(STDERR_FILENO);
  const int tenth = std::max(1, p.num_frames / 10);
  if (!terminal && p.frame % tenth != 0 && p.frame != p.num_frames) return;
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
  const bool terminal = isatty(STDERR_FILENO);
  const int twentieth = std::max(1, p.epochs / 20);
  if (!terminal && !p.validated && p.epoch % twentieth != 0 && p.epoch != p.epochs) return;
  std::fprintf(stderr, "  epoch %d/%d  loss %.3e (x %.2e F %.2e v %.2e)", p.epoch, p.epochs, p.train.total,
               p.train.position, p.train.gradient, p.train.velocity);
  if (p.validated) std::fprintf(stderr, "  validation %.3e", p.validation.total);
  std::fprintf(stderr, "  lr %.1e  %.3g samples/s  %s left\n", p.learning_rate, p.samples_per_second,
               duration_string(p.seconds_left).c_str());
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

  bool quiet = false;
  app.add_flag("-q,--quiet", quiet, "No progress on stderr");

  std::string scene_path, out_path;
  std::vector<std::string> overrides;
  mpmrom::P2GStrategy p2g = mpmrom::P2GStrategy::Atomic;
  auto* simulate = app.add_subcommand("simulate", "Run the full-order MPM model on a scene; write one snapshot file");
  simulate->add_option("scene", scene_path, "Scene file (TOML)")->required()->check(CLI::ExistingFile);
  simulate->add_option("--out", out_path, "Snapshot file to write (HDF5; an XDMF side file goes next to it)")
      ->required();
  simulate->add_option("--set", overrides, "Override: parameter=value, or a scene entry like material.density=500");
  simulate->add_option("--p2g", p2g, "Particle-to-grid accumulation: atomic or scatter")
      ->transform(CLI::CheckedTransformer(kP2GStrategies, CLI::ignore_case));
  simulate->footer("Example: mpmrom simulate scenes/poke_cylinder.toml --out poke.h5 --set rho=1.2");

  std::string sweep_dir;
  auto* sweep = app.add_subcommand("sweep", "Run the scene's parameter design: DIR/runs/*.h5 and DIR/design.csv");
  sweep->add_option("scene", scene_path, "Scene file (TOML) with a [design] table")->required()->check(CLI::ExistingFile);
  sweep->add_option("--out", sweep_dir, "Output directory")->required();
  sweep->add_option("--p2g", p2g, "Particle-to-grid accumulation: atomic or scatter")
      ->transform(CLI::CheckedTransformer(kP2GStrategies, CLI::ignore_case));
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
  bool train_json = false;
  train->add_flag("--json", train_json, "Print a benchmark record (device, time, settings, errors) as one JSON object on stdout");
  train->footer("Example: mpmrom train data/poke --out poke_model.h5\n"
                "Checkpoints go to MODEL.h5.ckpt while training and are removed once MODEL.h5 is written.");

  long bench_steps = 20, bench_warmup = 3;
  bool bench_json = false;
  auto* bench = app.add_subcommand("bench", "Time the solvers; --json prints one benchmark record on stdout");
  bench->require_subcommand(1);
  auto* bench_fom = bench->add_subcommand("fom", "Full-order MPM steps per second on a scene");
  bench_fom->add_option("scene", scene_path, "Scene file (TOML)")->required()->check(CLI::ExistingFile);
  bench_fom->add_option("--set", overrides, "Override: parameter=value, or a scene entry like grid.dx=0.02");
  bench_fom->add_option("--steps", bench_steps, "Timed steps")->check(CLI::PositiveNumber);
  bench_fom->add_option("--warmup", bench_warmup, "Untimed steps first")->check(CLI::NonNegativeNumber);
  bench_fom->add_option("--p2g", p2g, "Particle-to-grid accumulation: atomic or scatter")
      ->transform(CLI::CheckedTransformer(kP2GStrategies, CLI::ignore_case));
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

  try {
    mpmrom::KokkosSession kokkos(threads, device);
    const auto progress = [quiet](const mpmrom::SimulationProgress& p) { report_progress(p, quiet); };
    if (*simulate) {
      const mpmrom::Scene scene = mpmrom::load_scene(scene_path, overrides);
      if (!quiet) std::cerr << "mpmrom simulate: " << scene.name << " -> " << out_path << "\n";
      mpmrom::simulate(scene, out_path, p2g, progress);
    }
    if (*sweep) {
      mpmrom::sweep(scene_path, sweep_dir, p2g,
                    [&](std::size_t run, std::size_t num_runs, const mpmrom::SweepRun& r) {
                      if (!quiet)
                        std::cerr << "mpmrom sweep: run " << run + 1 << "/" << num_runs << " (" << r.file << ", "
                                  << (r.test ? "test" : "train") << ")\n";
                    },
                    progress);
    }
    if (*train) {
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
      const auto model = mpmrom::train_model(data, training, checkpoint, resume, callbacks);
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
    if (*bench_fom) {
      const mpmrom::Scene scene = mpmrom::load_scene(scene_path, overrides);
      const auto result = mpmrom::bench_fom(scene, p2g, bench_steps, bench_warmup);
      auto record = mpmrom::benchmark_record("fom_step", scene.name);
      record["p2g"] = p2g == mpmrom::P2GStrategy::Atomic ? "atomic" : "scatter";
      record["particles"] = result.particles;
      record["grid_nodes"] = result.grid_nodes;
      record["steps"] = result.steps;
      record["dt_s"] = result.dt;
      record["fom_step_seconds"] = result.seconds / result.steps;
      record["fom_particle_steps_per_s"] = double(result.particles) * result.steps / result.seconds;
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
  } catch (const std::exception& e) {
    std::cerr << "mpmrom: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
