#include "common.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <iostream>
#include <stdexcept>

#include "mpmrom/training_data.hpp"

namespace mpmrom::cli {

nlohmann::json to_json(const RuntimeInfo& info) {
  return {{"version", info.version},    {"git_commit", info.git_commit}, {"backend", info.backend},
          {"threads", info.threads},    {"device", info.device},         {"kokkos_version", info.kokkos_version},
          {"precision", info.precision}};
}

const std::map<std::string, P2GStrategy> kP2GStrategies{
    {"atomic", P2GStrategy::Atomic}, {"scatter", P2GStrategy::Scatter}, {"tiled", P2GStrategy::Tiled}};
const char* const kP2GHelp =
    "Particle-to-grid accumulation: scatter (per-thread grid copies; bitwise reproducible; default on CPUs), atomic "
    "(straight into the grid; default on GPUs) or tiled (teams sum into shared-memory tiles, then the grid)";

std::string p2g_name(P2GStrategy strategy) {
  for (const auto& [name, value] : kP2GStrategies)
    if (value == strategy) return name;
  return "";
}

namespace {
Verbosity verbosity = Verbosity::normal;
}  // namespace

void set_verbosity(Verbosity v) { verbosity = v; }

bool every_progress_line() { return verbosity == Verbosity::verbose || isatty(STDERR_FILENO); }

namespace {
// A function-local static: the check a host (the Python module) installs for its commands.
std::function<void()>& interruption_check() {
  static std::function<void()> check;
  return check;
}
}  // namespace

void set_interruption_check(std::function<void()> check) { interruption_check() = std::move(check); }

void check_interruption() {
  if (interruption_check()) interruption_check()();
}

void report_progress(const SimulationProgress& p, bool quiet) {
  check_interruption();
  if (quiet) return;
  const int tenth = std::max(1, p.num_frames / 10);
  if (!every_progress_line() && p.frame % tenth != 0 && p.frame != p.num_frames) return;
  const double rate = p.seconds > 0 ? double(p.steps) * double(p.num_particles) / p.seconds : 0;
  const double left = p.frame > 0 ? p.seconds * (p.num_frames - p.frame) / p.frame : 0;
  print_stderr("  frame %d/%d  t = %.4f s  %ld steps  %.3g particle-steps/s  %.1f s left\n", p.frame, p.num_frames,
               p.time, p.steps, rate, left);
}

void print_stderr(const char* format, ...) {
  std::va_list args, measure;
  va_start(args, format);
  va_copy(measure, args);
  std::string text(std::size_t(std::max(0, std::vsnprintf(nullptr, 0, format, measure))), '\0');
  va_end(measure);
  std::vsnprintf(text.data(), text.size() + 1, format, args);
  va_end(args);
  std::cerr << text;
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

void report_training(const TrainingProgress& p, bool quiet) {
  check_interruption();
  if (quiet) return;
  const int twentieth = std::max(1, p.epochs / 20);
  if (!every_progress_line() && !p.validated && p.epoch % twentieth != 0 && p.epoch != p.epochs) return;
  print_stderr("  epoch %d/%d  loss %.3e (x %.2e F %.2e v %.2e", p.epoch, p.epochs, p.train.total, p.train.position,
               p.train.gradient, p.train.velocity);
  if (p.train.affine > 0) print_stderr(" C %.2e", p.train.affine);
  print_stderr(")");
  if (p.validated) print_stderr("  validation %.3e", p.validation.total);
  print_stderr("  lr %.1e  %.3g samples/s  %s left\n", p.learning_rate, p.samples_per_second,
               duration_string(p.seconds_left).c_str());
}

std::string out_of_memory(const std::string& what) {
  return "mpmrom: error: out of memory (" + what.substr(0, what.find('\n')) +
         "): the run needs more memory than this machine or device has; use fewer points or a coarser grid\n";
}

std::vector<RolloutCase> rollout_cases(const Scene& scene, const std::string& params_path,
                                       std::vector<std::string>& names) {
  std::vector<RolloutCase> cases;
  names = scene.design.names;
  if (names.empty())
    for (const auto& [name, value] : scene.parameters) names.push_back(name);
  if (!params_path.empty()) {
    std::vector<std::vector<std::string>> columns;
    for (const auto& name : names) columns.push_back(design_column(params_path, name));
    std::vector<std::string> splits;
    try {
      splits = design_column(params_path, "split");
    } catch (const std::exception&) {
      // no split column: the rollouts' split stays unknown
    }
    const std::size_t rows = columns.empty() ? 0 : columns.front().size();
    for (std::size_t row = 0; row < rows; ++row) {
      RolloutCase c;
      for (std::size_t k = 0; k < names.size(); ++k) {
        try {
          std::size_t used = 0;
          c.values.push_back(std::stod(columns[k][row], &used));
          if (used != columns[k][row].size() || !std::isfinite(c.values.back()))
            throw std::invalid_argument("not a finite number");
        } catch (const std::exception&) {
          // rows counted as in a spreadsheet: the header is row 1
          throw std::runtime_error(params_path + ": row " + std::to_string(row + 2) + ", column '" + names[k] + "': '" +
                                   columns[k][row] + "' is not a finite number");
        }
      }
      if (!splits.empty()) c.split = splits[row];
      cases.push_back(c);
    }
    if (cases.empty()) throw std::runtime_error(params_path + ": no parameter rows");
    return cases;
  }
  if (!scene.design.names.empty()) {
    const auto runs = scene.design.all_runs();
    for (std::size_t r = 0; r < runs.size(); ++r) {
      bool test = false;
      for (const int t : scene.design.test_runs) test = test || std::size_t(t) == r;
      cases.push_back({runs[r], test ? "test" : "train"});
    }
    return cases;
  }
  RolloutCase c;
  for (const auto& name : names) c.values.push_back(scene.parameters.at(name));
  cases.push_back(c);
  return cases;
}

void print_metrics(const char* label, const nlohmann::json& e) {
  print_stderr("  %-8s position %.4f %%  displacement %.3f %%  velocity %.3f %%  F %.4f %%  strain %.3f %%\n", label,
               100 * e["position_error"].get<double>(), 100 * e["displacement_error"].get<double>(),
               100 * e["velocity_error"].get<double>(), 100 * e["F_error"].get<double>(),
               100 * e["strain_error"].get<double>());
}

std::function<void(const std::string&)> log_lines(bool quiet) {
  return [quiet](const std::string& text) {
    if (!quiet) std::cerr << "mpmrom: " << text << "\n";
  };
}

}  // namespace mpmrom::cli
