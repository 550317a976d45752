// A subcommand of the mpmrom program: each adds itself and its options to the parser (one file each) and runs
// when chosen. main.cpp holds the global options, the MPI and Kokkos sessions, and the error handling.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <vector>

#include "core/parallel.hpp"

namespace mpmrom::cli {

// What a command sees when it runs.
struct Context {
  bool quiet = false;
  const parallel::Communicator& world;
  int argc = 0;
  char** argv = nullptr;
};

struct Command {
  CLI::App* app = nullptr;                 // parsed() tells whether it was chosen
  std::function<bool()> shares_work;       // runs under mpirun, sharing its work among the ranks (docs/mpi.md)
  std::function<int(const Context&)> run;  // the exit status
};
using Commands = std::vector<Command>;

// An option whose --help shows its default value: the one idiom of the commands' options.
template <class T>
CLI::Option* add_defaulted(CLI::App* command, const std::string& name, T& value, const std::string& help) {
  return command->add_option(name, value, help)->capture_default_str();
}

// A required input that must exist: a file (the default) or, with CLI::ExistingPath, a file or a directory.
template <class T>
CLI::Option* add_input(CLI::App* command, const std::string& name, T& value, const std::string& help,
                       const CLI::Validator& exists = CLI::ExistingFile) {
  return command->add_option(name, value, help)->required()->check(exists);
}

// The network's shape, as train and bench nn take it.
inline void add_network_shape(CLI::App* command, int& latent_dim, int& width, int& depth) {
  add_defaulted(command, "--latent", latent_dim, "Latent dimension r");
  add_defaulted(command, "--width", width, "Hidden units per layer");
  add_defaulted(command, "--depth", depth, "Affine layers (depth - 1 hidden ELU layers)");
}

// The loss's weights (paper's (7) and the affine term), as train and pipeline take them.
inline void add_loss_weights(CLI::App* command, double& lambda_gradient, double& lambda_velocity,
                             double& lambda_affine) {
  add_defaulted(command, "--lambda-grad", lambda_gradient, "lambda1: weight of the dg/dX - F misfit (relative)");
  add_defaulted(command, "--lambda-vel", lambda_velocity,
                "lambda2: weight of the dg/dxhat xhatdot - v misfit (relative)");
  add_defaulted(command, "--lambda-affine", lambda_affine,
                "lambda3: weight of the Fdot - C F misfit, C the runs' APIC matrix (relative; not the paper's)");
}

// In the order `mpmrom --help` lists them.
void add_info(CLI::App& app, Commands& commands);
void add_simulate(CLI::App& app, Commands& commands);
void add_sweep(CLI::App& app, Commands& commands);
void add_train(CLI::App& app, Commands& commands);
void add_rollout(CLI::App& app, Commands& commands);
void add_evaluate(CLI::App& app, Commands& commands);
void add_upgrade(CLI::App& app, Commands& commands);
void add_stability(CLI::App& app, Commands& commands);
void add_pipeline(CLI::App& app, Commands& commands);
void add_bench(CLI::App& app, Commands& commands);

}  // namespace mpmrom::cli
