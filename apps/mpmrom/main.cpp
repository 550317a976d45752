// mpmrom: the command-line front end. Parsing and printing only; the work is done by the library. The options and
// subcommands live in program.cpp (one file per subcommand, command.hpp); this file holds the MPI and Kokkos sessions
// and turns every error into one line and an exit status (docs/cli.md).
#include <iostream>
#include <stdexcept>

#include "common.hpp"
#include "core/parallel.hpp"
#include "mpmrom/runtime.hpp"
#include "program.hpp"

int main(int argc, char** argv) {
  using namespace mpmrom::cli;
  Program program;
  try {
    program.app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return program.app.exit(e);
  }
  const Command& chosen = program.chosen();

  // Under mpirun (an MPI build), sweep, train and rollout share their work among the ranks (docs/mpi.md); rank 0
  // reports and writes the outputs, the others say nothing but errors.
  mpmrom::parallel::Session mpi(argc, argv);
  const auto world = mpmrom::parallel::Communicator::world();
  const bool quiet = program.quiet || !world.is_root();
  set_verbosity(quiet ? Verbosity::quiet : program.verbose ? Verbosity::verbose : Verbosity::normal);
  try {
    if (world.size() > 1 && !(chosen.shares_work && chosen.shares_work()))
      throw std::invalid_argument(
          "under mpirun, mpmrom runs sweep, train and rollout (without --target-error); "
          "run the other commands as one process");
    mpmrom::KokkosSession kokkos(program.threads, program.device, world.local_rank());
    if (program.verbose) {
      const auto runtime = mpmrom::runtime_info();
      std::cerr << "mpmrom " << runtime.version << " (" << runtime.git_commit << "): " << runtime.backend << ", "
                << runtime.threads << " threads, " << runtime.device << ", Kokkos " << runtime.kokkos_version << ", "
                << runtime.precision << "\n";
    }
    return chosen.run(Context{quiet, world, argc, argv});
  } catch (...) {
    const auto failure = describe_failure(std::current_exception());
    std::cerr << failure.line;
    // One rank's error ends them all: the others would wait for it in their next collective operation.
    if (world.size() > 1) world.abort(failure.status);
    return failure.status;
  }
}
