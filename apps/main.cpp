// mpmrom: the command-line front end. Parsing and printing only; the work is done by the library.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <exception>
#include <iostream>
#include <map>
#include <unistd.h>

#include "bench.hpp"
#include "mpmrom_config.hpp"
#include "runtime.hpp"
#include "simulate.hpp"

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
