// The pipeline's run (run_pipeline): the sweep, the FOM ladder, the networks (trained or searched), the batch
// benchmark of the chosen configuration, and the report.
#include "studies/pipeline.hpp"

#include <filesystem>

#include "core/benchmark_record.hpp"
#include "core/timing.hpp"
#include "io/atomic_file.hpp"
#include "snapshots/simulate.hpp"
#include "studies/detail/fom_ladder.hpp"
#include "studies/detail/format.hpp"
#include "studies/detail/pipeline_report.hpp"
#include "studies/detail/pipeline_study.hpp"

namespace mpmrom {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The scene's design swept into DIR/data (returned), or the sweep found there reused.
std::string sweep_data(const PipelineSettings& settings, const PipelineLog& say) {
  const std::string data_dir = (fs::path(settings.out_dir) / "data").string();
  if (fs::exists(fs::path(data_dir) / "design.csv")) {
    say("sweep: reusing " + data_dir);
  } else {
    say("sweep: the scene's design into " + data_dir);
    // A pipeline stopped during its sweep keeps the runs it finished (resume).
    sweep(
        settings.scene_path, data_dir, default_p2g_strategy(),
        [&](std::size_t run, std::size_t runs, const SweepRun&, bool reused) {
          say("  run " + std::to_string(run + 1) + "/" + std::to_string(runs) + (reused ? " (finished before)" : ""));
        },
        {}, true);
  }
  return data_dir;
}

// The networks given, else the training settings' own shape, or the search space with targets.
std::vector<NetworkShape> networks_to_try(const PipelineSettings& settings) {
  std::vector<NetworkShape> networks = settings.networks;
  if (networks.empty()) {
    if (settings.target_errors.empty())
      networks.push_back({settings.training.latent_dim, settings.training.width, settings.training.depth});
    else
      networks = default_search_networks(settings.training.depth);
  }
  return networks;
}

// The configuration the batch benchmark runs: the first target's choice; without targets, the cheapest
// configuration within 1 % on validation, else the most accurate one. nullptr: none.
const json* batch_choice(const json& targets, const PipelineStudy& study) {
  const json* chosen = !targets.empty() && !targets[0]["chosen"].is_null() ? &targets[0]["chosen"] : nullptr;
  if (targets.empty()) {
    const auto validation_error = [](const json& c) { return number(c["validation"]["position_error"]); };
    for (const auto& c : study.configurations())
      if (validation_error(c) <= 0.01 && (!chosen || number(c["cost_seconds_per_simulated_second"]) <
                                                         number((*chosen)["cost_seconds_per_simulated_second"])))
        chosen = &c;
    if (!chosen)
      for (const auto& c : study.configurations())
        if (!chosen || validation_error(c) < validation_error(*chosen)) chosen = &c;
  }
  return chosen;
}

}  // namespace

json run_pipeline(const PipelineSettings& settings, const PipelineLog& log) {
  const auto start = SteadyClock::now();
  const auto say = [&](const std::string& text) {
    if (log) log(text);
  };
  const fs::path out(settings.out_dir);
  fs::create_directories(out);
  const std::string data_dir = sweep_data(settings, say);
  PipelineStudy study(settings, settings.scene_path, data_dir, (out / "models").string(), log);
  const Scene& scene = study.scene();

  say("FOM at " + std::to_string(settings.fom_refinements.size()) + " resolutions and the " +
      general(settings.reference_refinement) + "x reference, on the test runs");
  std::vector<Snapshot> references;
  const json ladder = fom_ladder(settings, study, references);
  study.set_references(std::move(references));

  const std::vector<NetworkShape> networks = networks_to_try(settings);
  json targets = json::array();
  if (settings.target_errors.empty()) {
    for (const auto& shape : networks) study.open(shape);
  } else {
    targets = study.search_targets(settings.target_errors, networks);
  }

  json report = benchmark_record("pipeline", scene.name);
  report["command"] = !settings.command.empty()
                          ? settings.command
                          : "mpmrom pipeline " + settings.scene_path + " --out " + settings.out_dir;
  report["particles"] = study.test_runs().runs.front().num_points;
  report["reference_refinement"] = settings.reference_refinement;
  report["runs"] = {{"train", study.training_runs()},
                    {"validation", study.validation_runs().runs.size()},
                    {"test", study.test_runs().runs.size()}};
  report["fom"] = ladder;
  report["models"] = study.models();
  report["rom"] = study.configurations();
  report["targets"] = targets;
  report["comparison"] = {{"position_error", compare_fronts(ladder, study.configurations(), "position_error")},
                          {"displacement_error", compare_fronts(ladder, study.configurations(), "displacement_error")}};

  const json* chosen = batch_choice(targets, study);
  if (chosen && !settings.batch_sizes.empty()) {
    say("batch throughput of " + (*chosen)["network"].get<std::string>() + " " +
        (*chosen)["configuration"].get<std::string>());
    const auto& models = study.models();
    const auto& m = models[(*chosen)["network"].get<std::string>()];
    const RomConfiguration configuration{rom_method_from_string((*chosen)["method"].get<std::string>()),
                                         (*chosen)["samples"].get<int>(), (*chosen)["cfl"].get<double>()};
    report["batch"] = study.batch_throughput({m["latent_dim"].get<int>(), m["width"].get<int>(), m["depth"].get<int>()},
                                             configuration);
  }
  report["wall_seconds"] = seconds_since(start);
  const auto problems = draw_pipeline_charts(settings.out_dir, report);
  for (const auto& p : problems) say("charts: " + p);
  write_file_atomically((out / "report.json").string(), report.dump(1) + "\n");
  write_file_atomically((out / "report.md").string(), pipeline_markdown(report, problems));
  say("wrote " + (out / "report.md").string() + " and report.json");
  return report;
}

}  // namespace mpmrom
