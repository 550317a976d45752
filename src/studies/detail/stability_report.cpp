// The stability map's report: stability.json (StabilityCase::to_json), stability.md (a table per study) and the
// charts (stability_report.hpp).
#include "studies/detail/stability_report.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>

#include "core/benchmark_record.hpp"
#include "io/atomic_file.hpp"
#include "studies/charts.hpp"
#include "studies/detail/format.hpp"

namespace mpmrom {
namespace {

std::string stability_markdown(const StabilitySettings& settings, const std::vector<StabilityCase>& cases,
                               const Model& model, const std::string& scene_name) {
  std::ostringstream md;
  md << "# Stability map: " << scene_name << "\n\n"
     << "Model `" << settings.model_path << "` (r = " << model.latent_dim
     << "). Hyper-reduced configurations: " << settings.samples << " samples, "
     << (settings.selection ? "`--selection " + to_string(*settings.selection) + "`"
                            : std::string("each method's default selection (as a rollout without flags)"))
     << ". Each case runs to its end or to the "
     << "first detector that trips; errors are against the full-order model at the scene's time step with the same "
     << "parameters, material and horizon. **unstable**: a detector stopped it; **inaccurate**: position error above "
     << percent(settings.threshold, "-")
     << "; **stable** otherwise. Time step: the CFL number (1 is the explicit limit). "
     << "Extrapolation: distance beyond the top of the training range in widths of it, every parameter together "
     << "(-0.5 is the centre of the range, 0 its corner).\n";
  const auto table = [&](const std::string& study, const std::string& title) {
    md << "\n## " << title << "\n\n| configuration | time step | horizon | extrapolation | load | material | status | "
       << "position error | final | displacement error | stopped at (s) | cause | wall s |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& c : cases) {
      if (c.study != study) continue;
      md << "| " << c.config << " | " << general(c.cfl) << " | " << general(c.horizon) << "x | "
         << general(c.extrapolation) << " | " << general(c.load_factor) << " | "
         << (c.material.empty() ? "scene" : c.material) << " | " << c.status << " | " << percent(c.position_error, "-")
         << " | " << percent(c.final_position_error, "-") << " | " << percent(c.displacement_error, "-") << " | "
         << (c.stopped_at >= 0 ? general(c.stopped_at) : "-") << " | " << c.cause << " | " << general(c.seconds)
         << " |\n";
    }
  };
  table("time_step", "Time step and parameter extrapolation");
  table("horizon", "Horizon");
  table("samples", "Sample points (hyper-reduction)");
  table("material", "Material");
  table("load", "Load (Algorithm 2's Newton inversion)");
  return md.str();
}

// One map per configuration: time step x extrapolation, error as colour, unstable cells marked.
void draw_maps(const std::string& dir, const std::vector<StabilityCase>& cases, const std::string& scene_name) {
  std::map<std::string, std::vector<const StabilityCase*>> by_config;
  for (const auto& c : cases)
    if (c.study == "time_step") by_config[c.config].push_back(&c);
  for (const auto& [config, list] : by_config) {
    Chart chart{"Stability map, " + scene_name + ": " + config,
                "time step (CFL number)",
                "extrapolation beyond the training range (widths; -0.5 = centre)",
                true,
                false,
                "position error (fraction)",
                true,
                {}};
    ChartSeries ok{"stable / inaccurate: colour = position error", {}, {}, "points pt 5 ps 4", {}, {}};
    ChartSeries bad{"unstable (detector)", {}, {}, "points pt 2 ps 3", {}, {}};
    for (const StabilityCase* c : list) {
      const bool broken = c->status == "unstable" || c->status == "no reference";
      ChartSeries& s = broken ? bad : ok;
      s.x.push_back(c->cfl);
      s.y.push_back(c->extrapolation);
      if (!broken) s.color.push_back(std::max(c->position_error, 1e-6));
      s.labels.push_back(broken ? c->cause.substr(0, c->cause.find_first_of(":(;")) : percent(c->position_error, "-"));
    }
    chart.series = {ok, bad};
    write_chart(dir, "map_" + file_label(config), chart);
  }
}

// Error growth over the longest horizon.
void draw_horizon_error(const std::string& dir, const StabilitySettings& settings,
                        const std::vector<StabilityCase>& cases, const std::string& scene_name) {
  Chart growth{"Position error over time, " + scene_name + ": a horizon of " + general(settings.horizons.back()) +
                   "x the training window",
               "time (s)",
               "position error (fraction)",
               false,
               true,
               "",
               false,
               {}};
  for (const auto& c : cases)
    if (c.study == "horizon" && c.horizon == settings.horizons.back())
      growth.series.push_back(
          {c.config + (c.status == "unstable" ? " (stopped)" : ""), c.times, c.frame_position_errors, "lines", {}, {}});
  write_chart(dir, "horizon_error", growth);
}

// Error against the number of samples.
void draw_samples_error(const std::string& dir, const std::vector<StabilityCase>& cases, const Model& model,
                        const std::string& scene_name) {
  Chart samples{"Position error against sample points, " + scene_name,
                "sample points",
                "position error (fraction)",
                true,
                true,
                "",
                false,
                {}};
  for (const std::string method : {"point", "node"}) {
    ChartSeries s{method_title(method), {}, {}, "linespoints", {}, {}};
    for (const auto& c : cases)
      if (c.study == "samples" && c.method == method && c.status != "unstable") {
        s.x.push_back(c.samples > 0 ? c.samples : double(model.num_points()));
        s.y.push_back(c.position_error);
      }
    samples.series.push_back(s);
  }
  write_chart(dir, "samples_error", samples);
}

}  // namespace

nlohmann::json StabilityCase::to_json() const {
  const auto finite_or_null = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  nlohmann::json errors = nlohmann::json::array();
  for (const double e : frame_position_errors) errors.push_back(finite_or_null(e));
  return {{"study", study},
          {"config", config},
          {"method", method},
          {"samples", samples},
          {"cfl", cfl},
          {"horizon", horizon},
          {"extrapolation", extrapolation},
          {"load_factor", load_factor},
          {"material", material},
          {"values", values},
          {"status", status},
          {"cause", cause},
          {"stopped_at", stopped_at},
          {"position_error", finite_or_null(position_error)},
          {"displacement_error", finite_or_null(displacement_error)},
          {"final_position_error", finite_or_null(final_position_error)},
          {"times", times},
          {"frame_position_errors", errors},
          {"seconds", seconds},
          {"details", details}};
}

std::string file_label(std::string text) {
  for (char& ch : text)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return text;
}

void write_stability_report(const StabilitySettings& settings, const std::vector<StabilityCase>& cases,
                            const Model& model, const std::string& scene_name) {
  const std::filesystem::path dir(settings.out_dir);
  nlohmann::json record = benchmark_record("stability", scene_name);
  record["model"] = settings.model_path;
  record["latent_dim"] = model.latent_dim;
  record["threshold"] = settings.threshold;
  record["samples"] = settings.samples;
  record["selection"] = settings.selection ? to_string(*settings.selection) : std::string("auto");
  record["cases"] = nlohmann::json::array();
  for (const auto& c : cases) record["cases"].push_back(c.to_json());
  write_file_atomically((dir / "stability.json").string(), record.dump(1) + "\n");
  write_file_atomically((dir / "stability.md").string(), stability_markdown(settings, cases, model, scene_name));
  draw_maps(dir.string(), cases, scene_name);
  draw_horizon_error(dir.string(), settings, cases, scene_name);
  draw_samples_error(dir.string(), cases, model, scene_name);
}

}  // namespace mpmrom
