// The FOM's resolution ladder and the comparison of the two models' fronts (fom_ladder.hpp), and the Pareto front
// itself (pipeline.hpp).
#include "studies/detail/fom_ladder.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "analysis/evaluation.hpp"
#include "snapshots/simulate.hpp"
#include "studies/detail/format.hpp"

namespace mpmrom {

namespace fs = std::filesystem;
using nlohmann::json;

// Indices of the points on the lower-left Pareto front of (cost, error), by increasing cost.
std::vector<std::size_t> pareto_front(const std::vector<double>& cost, const std::vector<double>& error) {
  std::vector<std::size_t> order(cost.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return cost[a] < cost[b] || (cost[a] == cost[b] && error[a] < error[b]);
  });
  std::vector<std::size_t> front;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i : order)
    if (std::isfinite(error[i]) && error[i] < best) {
      front.push_back(i);
      best = error[i];
    }
  return front;
}

// The FOM's resolution ladder on the test runs: every level against the reference, with its cost.
json fom_ladder(const PipelineSettings& settings, const PipelineStudy& study, std::vector<Snapshot>& references) {
  const Scene& scene = study.scene();
  const auto& names = scene.design.names;
  struct Level {
    double refinement, cfl;
    bool reference;
  };
  std::vector<Level> levels{{settings.reference_refinement, 0, true}};
  for (double cfl : settings.fom_cfls)
    for (double f : settings.fom_refinements) levels.push_back({f, cfl, false});
  json ladder = json::array();
  for (const auto& level : levels) {
    const std::string name =
        level.reference ? "reference"
                        : "x" + general(level.refinement) + "_cfl" + general(level.cfl > 0 ? level.cfl : scene.cfl);
    const fs::path dir = fs::path(settings.out_dir) / "fom" / name;
    fs::create_directories(dir);
    ErrorAccumulator errors;
    double step_seconds = 0, simulated = 0;
    long steps = 0;
    std::size_t particles = 0;
    double dx = 0;
    for (std::size_t t = 0; t < study.test_runs().runs.size(); ++t) {
      Scene run = refine_scene(scene_for_run(settings.scene_path, names, run_values(study.test_runs().runs[t], names)),
                               level.refinement);
      if (level.cfl > 0) run = override_scene(run, {"time.cfl=" + general(level.cfl, 17)});
      const std::string path = (dir / fs::path(study.test_runs().files[t]).filename()).string();
      SimulationProgress last{};
      simulate(run, path, default_p2g_strategy(), [&](const SimulationProgress& p) { last = p; });
      step_seconds += last.step_seconds;
      steps += last.steps;
      simulated += run.end_time;
      particles = last.num_particles;
      dx = run.dx;
      if (level.reference)
        references.push_back(read_snapshot(path, SnapshotFields::WithoutAffine));
      else
        errors.merge(resolution_errors(references[t], read_snapshot(path)));
    }
    json entry = {{"name", name},
                  {"refinement", level.refinement},
                  {"cfl", level.cfl > 0 ? level.cfl : scene.cfl},
                  {"dx", dx},
                  {"particles", particles},
                  {"runs", study.test_runs().runs.size()},
                  {"steps_per_run", double(steps) / study.test_runs().runs.size()},
                  {"fom_step_seconds", step_seconds / steps},
                  {"cost_seconds_per_simulated_second", step_seconds / simulated},
                  {"reference", level.reference}};
    if (!level.reference) entry["test_vs_reference"] = metrics_json(errors);
    study.say("FOM " + name + ": " + std::to_string(particles) + " particles, " + general(step_seconds / simulated) +
              " s per simulated second" +
              (level.reference
                   ? " (the reference)"
                   : ", position error " + percent(entry["test_vs_reference"]["position_error"], "failed")));
    ladder.push_back(entry);
  }
  return ladder;
}

// The ROM's Pareto front against the FOM ladder: for each front point, the best FOM error at equal or lower cost.
json compare_fronts(const json& ladder, const std::vector<json>& configurations, const std::string& metric) {
  std::vector<double> fom_cost, fom_error;
  for (const auto& level : ladder)
    if (!level["reference"].get<bool>()) {
      fom_cost.push_back(level["cost_seconds_per_simulated_second"]);
      fom_error.push_back(number(level["test_vs_reference"][metric]));
    }
  std::vector<double> rom_cost, rom_error;
  for (const auto& c : configurations) {
    rom_cost.push_back(c["cost_seconds_per_simulated_second"]);
    rom_error.push_back(c.contains("test_vs_reference") ? number(c["test_vs_reference"][metric])
                                                        : std::numeric_limits<double>::infinity());
  }
  json points = json::array();
  double below_lo = INFINITY, below_hi = 0;
  int below = 0;
  const auto front = pareto_front(rom_cost, rom_error);
  for (std::size_t i : front) {
    double fom_best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < fom_cost.size(); ++k)
      if (fom_cost[k] <= rom_cost[i]) fom_best = std::min(fom_best, fom_error[k]);
    const bool rom_better = rom_error[i] < fom_best;
    if (rom_better) {
      ++below;
      below_lo = std::min(below_lo, rom_cost[i]);
      below_hi = std::max(below_hi, rom_cost[i]);
    }
    points.push_back({{"network", configurations[i]["network"]},
                      {"configuration", configurations[i]["configuration"]},
                      {"cost_seconds_per_simulated_second", rom_cost[i]},
                      {"error", rom_error[i]},
                      {"best_fom_error_at_equal_or_lower_cost",
                       std::isfinite(fom_best) ? json(fom_best) : json("no FOM level this cheap")},
                      {"rom_below_fom", rom_better}});
  }
  json result = {{"metric", metric}, {"front", points}, {"front_points_below_fom", below}};
  if (below > 0) result["range_seconds_per_simulated_second"] = {below_lo, below_hi};
  return result;
}

}  // namespace mpmrom
