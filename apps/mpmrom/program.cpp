#include "program.hpp"

#include <new>
#include <stdexcept>

#include "common.hpp"
#include "mpmrom/mpmrom_config.hpp"
#include "mpmrom/runtime.hpp"
#include "snapshots/simulate.hpp"

namespace mpmrom::cli {

Program::Program() {
  app.set_version_flag("--version", std::string("mpmrom ") + MPMROM_VERSION_STRING + " (" + mpmrom::git_commit() +
                                        ", " + MPMROM_PRECISION_NAME + ")");
  app.require_subcommand(1);
  app.add_option("--threads", threads, "CPU threads for the OpenMP backend (default: OMP_NUM_THREADS or all cores)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--device", device, "GPU index for the CUDA backend (default: 0)")->check(CLI::NonNegativeNumber);
  add_info(app, commands_);  // before -q and -v: `mpmrom --help` lists them in this order
  auto* quiet_flag = app.add_flag("-q,--quiet", quiet, "Nothing on stderr but errors and warnings");
  app.add_flag("-v,--verbose", verbose,
               "Every progress line (also when stderr is not a terminal), after a line naming the backend and device")
      ->excludes(quiet_flag);
  app.set_config("--config", "",
                 "Read options from a TOML file: top-level keys for global options, a [section] per subcommand "
                 "(docs/cli.md)");
  for (const auto add : {add_simulate, add_sweep, add_train, add_rollout, add_evaluate, add_upgrade, add_stability,
                         add_pipeline, add_bench})
    add(app, commands_);
}

const Command& Program::chosen() const {
  for (const auto& command : commands_)
    if (command.app->parsed()) return command;
  throw std::logic_error("no subcommand was parsed");
}

Failure describe_failure(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const mpmrom::SimulationFailure& e) {
    return {3, "mpmrom: the simulation failed (" + to_string(e.cause()) + ") at " + e.what() + "\n"};
  } catch (const std::bad_alloc& e) {
    return {1, out_of_memory(e.what())};
  } catch (const std::exception& e) {
    // Kokkos reports a failed View allocation as a runtime error of several lines.
    const std::string what = e.what();
    return {1, what.rfind("Kokkos failed to allocate", 0) == 0 ? out_of_memory(what) : "mpmrom: error: " + what + "\n"};
  }
}

}  // namespace mpmrom::cli
