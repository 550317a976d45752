// What the subcommands share: progress lines, the P2G option, parameter files, error lines.
#pragma once

#include <nlohmann/json.hpp>

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "fom/fom.hpp"
#include "manifold/trainer.hpp"
#include "mpmrom/rom.hpp"
#include "mpmrom/runtime.hpp"
#include "snapshots/simulate.hpp"

namespace mpmrom::cli {

nlohmann::json to_json(const RuntimeInfo& info);

extern const std::map<std::string, P2GStrategy> kP2GStrategies;
extern const char* const kP2GHelp;
std::string p2g_name(P2GStrategy strategy);

// How much goes to stderr: nothing (--quiet), progress lines thinned out when stderr is not a terminal (a log file),
// or every line (--verbose). Set once by main.
enum class Verbosity { quiet, normal, verbose };
void set_verbosity(Verbosity verbosity);
bool every_progress_line();

// Where a command can stop early: each progress report (a frame of a simulation or a rollout batch, an epoch of
// training) first calls the interruption check, which throws Interrupted to stop the command. The Python module
// installs one that looks for Ctrl-C; the program installs none (SIGINT ends it).
struct Interrupted {};
void set_interruption_check(std::function<void()> check);
void check_interruption();

// One progress line per tenth of a run (every frame on a terminal), with the rate and the time left.
void report_progress(const SimulationProgress& p, bool quiet);
// One line per epoch on a terminal, about 20 per run otherwise (and every validated epoch).
void report_training(const TrainingProgress& p, bool quiet);
std::string duration_string(double seconds);
// printf to std::cerr (not to the C stream): where std::cerr goes, the Python module's log included.
void print_stderr(const char* format, ...) __attribute__((format(printf, 1, 2)));
// "mpmrom: TEXT" on stderr unless quiet: the pipeline's and the model search's log.
std::function<void(const std::string&)> log_lines(bool quiet);

// One line for a failed allocation; Kokkos' own message runs over several, its first names the allocation.
std::string out_of_memory(const std::string& what);

// Rollout cases from a parameter file (design.csv form: a column per parameter name, optional split) or, without
// one, the scene's design (or the scene as it is when it has none).
std::vector<RolloutCase> rollout_cases(const Scene& scene, const std::string& params_path,
                                       std::vector<std::string>& names);

void print_metrics(const char* label, const nlohmann::json& e);

}  // namespace mpmrom::cli
