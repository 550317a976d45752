// mpmrom simulate (one full-order run) and mpmrom sweep (every run of the scene's design).
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "core/timing.hpp"

#include "command.hpp"
#include "common.hpp"

namespace mpmrom::cli {

void add_simulate(CLI::App& app, Commands& commands) {
  struct Options {
    std::string scene_path, out_path;
    std::vector<std::string> overrides;
    P2GStrategy p2g = default_p2g_strategy();
  };
  auto o = std::make_shared<Options>();
  auto* simulate = app.add_subcommand("simulate", "Run the full-order MPM model on a scene; write one snapshot file");
  add_input(simulate, "scene", o->scene_path, "Scene file (TOML)");
  simulate->add_option("--out", o->out_path, "Snapshot file to write (HDF5; an XDMF side file goes next to it)")
      ->required();
  simulate->add_option("--set", o->overrides, "Override: parameter=value, or a scene entry like material.density=500");
  simulate->add_option("--p2g", o->p2g, kP2GHelp)->transform(CLI::CheckedTransformer(kP2GStrategies, CLI::ignore_case));
  simulate->footer("Example: mpmrom simulate scenes/poke_cylinder.toml --out poke.h5 --set rho=1.2");
  commands.push_back({simulate, nullptr, [o](const Context& context) {
                        const Scene scene = load_scene(o->scene_path, o->overrides);
                        if (!context.quiet)
                          std::cerr << "mpmrom simulate: " << scene.name << " -> " << o->out_path << "\n";
                        const bool quiet = context.quiet;
                        mpmrom::simulate(scene, o->out_path, o->p2g,
                                         [quiet](const SimulationProgress& p) { report_progress(p, quiet); });
                        return 0;
                      }});
}

void add_sweep(CLI::App& app, Commands& commands) {
  struct Options {
    std::string scene_path, sweep_dir;
    bool resume = false;
    P2GStrategy p2g = default_p2g_strategy();
  };
  auto o = std::make_shared<Options>();
  auto* sweep = app.add_subcommand("sweep", "Run the scene's parameter design: DIR/runs/*.h5 and DIR/design.csv");
  add_input(sweep, "scene", o->scene_path, "Scene file (TOML) with a [design] table");
  sweep->add_option("--out", o->sweep_dir, "Output directory")->required();
  sweep->add_option("--p2g", o->p2g, kP2GHelp)->transform(CLI::CheckedTransformer(kP2GStrategies, CLI::ignore_case));
  sweep->add_flag("--resume", o->resume,
                  "Keep the runs a stopped sweep finished (same scene and parameters) and simulate the rest");
  sweep->footer("Example: mpmrom sweep scenes/poke_cylinder.toml --out data/poke");
  commands.push_back(
      {sweep, [] { return true; },
       [o](const Context& context) {
         const auto& world = context.world;
         const bool quiet = context.quiet;
         // The sweep's time left from the runs simulated so far (runs kept from before take no time).
         const auto start = SteadyClock::now();
         std::size_t simulated = 0;
         const auto report_run = [&](std::size_t run, std::size_t num_runs, const SweepRun& r, bool reused) {
           const double elapsed = seconds_since(start);
           std::string left;
           // this process's runs left: every world.size()-th run from here
           const std::size_t mine_left = (num_runs - run + world.size() - 1) / world.size();
           if (simulated > 0) left = ", " + duration_string(elapsed / double(simulated) * double(mine_left)) + " left";
           if (!reused) ++simulated;
           if (!quiet)
             std::cerr << "mpmrom sweep: run " << run + 1 << "/" << num_runs << " (" << r.file << ", "
                       << (r.test ? "test" : "train") << (reused ? ", finished before: kept" : "") << left << ")\n";
         };
         mpmrom::sweep(
             o->scene_path, o->sweep_dir, o->p2g, report_run,
             [quiet](const SimulationProgress& p) { report_progress(p, quiet); }, o->resume, world);
         return 0;
       }});
}

}  // namespace mpmrom::cli
