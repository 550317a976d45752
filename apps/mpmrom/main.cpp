// mpmrom: the command-line front end. Parsing and printing only; the work is done by the library. Each subcommand
// lives in its own file (command.hpp); this one holds the global options, the MPI and Kokkos sessions, and turns
// every error into one line and an exit status (docs/cli.md).
#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>
#include <new>
#include <stdexcept>
#include <string>

#include "command.hpp"
#include "common.hpp"
#include "core/parallel.hpp"
#include "mpmrom/mpmrom_config.hpp"
#include "mpmrom/runtime.hpp"
#include "snapshots/simulate.hpp"

int main(int argc, char** argv) {
  using namespace mpmrom::cli;
  CLI::App app{"mpmrom: material point method and its neural reduced-order model, on Kokkos"};
  app.set_version_flag("--version", std::string("mpmrom ") + MPMROM_VERSION_STRING + " (" + mpmrom::git_commit() +
                                        ", " + MPMROM_PRECISION_NAME + ")");
  app.require_subcommand(1);
  int threads = 0;
  int device = -1;
  app.add_option("--threads", threads, "CPU threads for the OpenMP backend (default: OMP_NUM_THREADS or all cores)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--device", device, "GPU index for the CUDA backend (default: 0)")->check(CLI::NonNegativeNumber);

  Commands commands;
  add_info(app, commands);  // before -q and -v: `mpmrom --help` lists them in this order
  bool quiet = false, verbose = false;
  auto* quiet_flag = app.add_flag("-q,--quiet", quiet, "Nothing on stderr but errors and warnings");
  app.add_flag("-v,--verbose", verbose,
               "Every progress line (also when stderr is not a terminal), after a line naming the backend and device")
      ->excludes(quiet_flag);
  app.set_config("--config", "",
                 "Read options from a TOML file: top-level keys for global options, a [section] per subcommand "
                 "(docs/cli.md)");
  for (const auto add : {add_simulate, add_sweep, add_train, add_rollout, add_evaluate, add_upgrade, add_stability,
                         add_pipeline, add_bench})
    add(app, commands);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  const Command* chosen = nullptr;
  for (const auto& command : commands)
    if (command.app->parsed()) chosen = &command;

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
  set_verbosity(quiet ? Verbosity::quiet : verbose ? Verbosity::verbose : Verbosity::normal);
  try {
    if (world.size() > 1 && !(chosen->shares_work && chosen->shares_work()))
      throw std::invalid_argument(
          "under mpirun, mpmrom runs sweep, train and rollout (without --target-error); "
          "run the other commands as one process");
    mpmrom::KokkosSession kokkos(threads, device, world.local_rank());
    if (verbose) {
      const auto runtime = mpmrom::runtime_info();
      std::cerr << "mpmrom " << runtime.version << " (" << runtime.git_commit << "): " << runtime.backend << ", "
                << runtime.threads << " threads, " << runtime.device << ", Kokkos " << runtime.kokkos_version << ", "
                << runtime.precision << "\n";
    }
    return chosen->run(Context{quiet, world, argc, argv});
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
}
