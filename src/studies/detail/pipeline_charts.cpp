// The pipeline report's charts: error against cost (two metrics), step cost against particles, batch throughput and
// training loss (pipeline_report.hpp).
#include <algorithm>
#include <map>

#include "mpmrom/rom.hpp"
#include "studies/charts.hpp"
#include "studies/detail/format.hpp"
#include "studies/detail/pipeline_report.hpp"
#include "studies/pipeline.hpp"

namespace mpmrom {
namespace {

using nlohmann::json;

// Error against cost on the test runs: the FOM ladder (a line per cfl), the ROM configurations (a series per
// algorithm) and the ROM's Pareto front.
Chart error_chart(const json& report, const std::string& metric) {
  const auto& ladder = report["fom"];
  const auto& configurations = report["rom"];
  Chart chart;
  chart.title = report["scene"].get<std::string>() + ": error against cost (test runs, against the " +
                general(report["reference_refinement"].get<double>()) + "x finer FOM)";
  chart.x_label = "cost: wall seconds per simulated second per run (" + report["device"].get<std::string>() + ")";
  chart.y_label = metric + " (%)";
  chart.log_x = chart.log_y = true;
  std::map<double, ChartSeries> fom_by_cfl;
  for (const auto& level : ladder) {
    if (level["reference"].get<bool>()) continue;
    auto& series = fom_by_cfl[level["cfl"].get<double>()];
    series.title = "FOM, resolutions (cfl " + general(level["cfl"].get<double>()) + ")";
    series.style = "linespoints";
    series.x.push_back(level["cost_seconds_per_simulated_second"]);
    series.y.push_back(100 * number(level["test_vs_reference"][metric]));
    series.labels.push_back("x" + general(level["refinement"].get<double>()));
  }
  std::vector<double> cost, error;
  std::map<std::string, ChartSeries> rom_by_method;
  for (const auto& c : configurations) {
    cost.push_back(c["cost_seconds_per_simulated_second"]);
    error.push_back(number(c["test_vs_reference"][metric]));
    auto& series = rom_by_method[c["method"].get<std::string>()];
    series.title = "ROM configurations, " + method_title(c["method"].get<std::string>());
    series.x.push_back(cost.back());
    series.y.push_back(100 * error.back());
  }
  for (auto& [cfl, series] : fom_by_cfl) chart.series.push_back(series);
  for (auto& [method, series] : rom_by_method) chart.series.push_back(series);
  ChartSeries front{"ROM Pareto front", {}, {}, "linespoints", {}, {}};
  for (std::size_t i : pareto_front(cost, error)) {
    front.x.push_back(cost[i]);
    front.y.push_back(100 * error[i]);
    front.labels.push_back(configurations[i]["network"].get<std::string>() + " " +
                           configurations[i]["configuration"].get<std::string>());
  }
  chart.series.push_back(front);
  return chart;
}

// The cost of one step against the particle count: the FOM at the first cfl and the reference, the ROM
// configurations at the model's points.
Chart step_cost_chart(const json& report) {
  const auto& ladder = report["fom"];
  Chart chart;
  chart.title = report["scene"].get<std::string>() + ": cost of one step against the particle count";
  chart.x_label = "material points (FOM particles; ROM: the model's points)";
  chart.y_label = "wall seconds per step (ROM: per rollout-step)";
  chart.log_x = chart.log_y = true;
  ChartSeries fom{"FOM, scene's cfl", {}, {}, "linespoints", {}, {}},
      rom{"ROM configurations", {}, {}, "points", {}, {}};
  for (const auto& level : ladder)
    if (level["cfl"] == ladder[0]["cfl"] || level["reference"].get<bool>()) {
      fom.x.push_back(level["particles"]);
      fom.y.push_back(level["fom_step_seconds"]);
    }
  for (const auto& c : report["rom"]) {
    rom.x.push_back(report["particles"]);
    rom.y.push_back(c["rom_seconds_per_rollout_step"]);
  }
  // ascending particle count so the line reads left to right
  std::vector<std::size_t> order(fom.x.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return fom.x[a] < fom.x[b]; });
  ChartSeries sorted{fom.title, {}, {}, fom.style, {}, {}};
  for (std::size_t i : order) {
    sorted.x.push_back(fom.x[i]);
    sorted.y.push_back(fom.y[i]);
  }
  chart.series = {sorted, rom};
  return chart;
}

// Rollout-steps per second against the batch size.
Chart batch_chart(const json& report) {
  Chart chart;
  chart.title = "Batch throughput: " + report["batch"]["network"].get<std::string>() + " " +
                report["batch"]["configuration"].get<std::string>();
  chart.x_label = "rollouts in the batch";
  chart.y_label = "rollout-steps per second";
  chart.log_x = chart.log_y = true;
  ChartSeries series{report["device"].get<std::string>() + " (" + report["backend"].get<std::string>() + ")",
                     {},
                     {},
                     "linespoints",
                     {},
                     {}};
  for (const auto& p : report["batch"]["points"]) {
    series.x.push_back(p["batch"]);
    series.y.push_back(p["rom_rollout_steps_per_s"]);
  }
  chart.series = {series};
  return chart;
}

// Each trained network's loss per epoch (none: networks reused without a history).
Chart training_loss_chart(const json& report) {
  Chart chart;
  chart.title = "Training loss (7), relative terms summed";
  chart.x_label = "epoch";
  chart.y_label = "minibatch loss";
  chart.log_y = true;
  for (const auto& [name, model] : report["models"].items()) {
    ChartSeries series{name, {}, {}, "lines", {}, {}};
    for (const auto& h : model["loss_history"]) {
      series.x.push_back(h["epoch"]);
      series.y.push_back(h["loss"]);
    }
    if (!series.x.empty()) chart.series.push_back(series);
  }
  return chart;
}

}  // namespace

std::vector<std::string> draw_pipeline_charts(const std::string& dir, const json& report) {
  std::vector<std::string> problems;
  const auto draw = [&](const std::string& name, const Chart& chart) {
    const std::string problem = write_chart(dir, name, chart);
    if (!problem.empty()) problems.push_back(problem);
  };
  for (const std::string metric : {"position_error", "displacement_error"})
    draw(metric == "position_error" ? "error_vs_cost" : "error_vs_cost_displacement", error_chart(report, metric));
  draw("step_cost_vs_particles", step_cost_chart(report));
  if (report.contains("batch")) draw("batch_throughput", batch_chart(report));
  const Chart loss = training_loss_chart(report);
  if (!loss.series.empty()) draw("training_loss", loss);
  return problems;
}

}  // namespace mpmrom
