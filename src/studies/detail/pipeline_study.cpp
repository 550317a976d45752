// The pipeline's study: runs held out for validation, networks trained or reused, every reduced configuration
// evaluated on the validation and test runs, and the batch benchmark (pipeline_study.hpp).
#include "studies/detail/pipeline_study.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <stdexcept>

#include "analysis/evaluation.hpp"
#include "io/atomic_file.hpp"
#include "studies/detail/format.hpp"

namespace mpmrom {

namespace fs = std::filesystem;
using nlohmann::json;

// Training runs held out to choose models: those with the most parameters at interior levels of the design (the
// runs most like interpolation, as the test runs are), evenly spread over the design order.
std::vector<std::size_t> validation_runs(const Scene& scene, int requested) {
  const auto runs = scene.design.all_runs();
  std::vector<std::size_t> train;
  for (std::size_t r = 0; r < runs.size(); ++r)
    if (std::find(scene.design.test_runs.begin(), scene.design.test_runs.end(), int(r)) == scene.design.test_runs.end())
      train.push_back(r);
  const std::size_t wanted = requested >= 0 ? std::size_t(requested) : std::max<std::size_t>(1, (train.size() + 3) / 6);
  if (wanted >= train.size())
    throw std::runtime_error("cannot hold out " + std::to_string(wanted) + " of " + std::to_string(train.size()) +
                             " training runs for validation");
  std::map<int, std::vector<std::size_t>, std::greater<int>> by_interior;
  for (std::size_t r : train) {
    int interior = 0;
    for (std::size_t k = 0; k < scene.design.names.size(); ++k) {
      double lo = runs[0][k], hi = runs[0][k];
      for (const auto& run : runs) {
        lo = std::min(lo, run[k]);
        hi = std::max(hi, run[k]);
      }
      interior += runs[r][k] > lo && runs[r][k] < hi;
    }
    by_interior[interior].push_back(r);
  }
  std::vector<std::size_t> chosen;
  for (const auto& [interior, group] : by_interior) {
    const std::size_t take = std::min(group.size(), wanted - chosen.size());
    for (std::size_t i = 0; i < take; ++i) chosen.push_back(group[(2 * i + 1) * group.size() / (2 * take)]);
    if (chosen.size() == wanted) break;
  }
  std::sort(chosen.begin(), chosen.end());
  return chosen;
}

std::vector<double> run_values(const Snapshot& run, const std::vector<std::string>& names) {
  std::vector<double> values;
  for (const auto& name : names) {
    bool found = false;
    for (const auto& [n, v] : run.header.parameters)
      if (n == name) {
        values.push_back(v);
        found = true;
      }
    if (!found) throw std::runtime_error("a run lacks the design parameter '" + name + "'");
  }
  return values;
}

json metrics_json(const ErrorAccumulator& errors) { return to_json(errors.metrics()); }

PipelineStudy::PipelineStudy(const PipelineSettings& settings, const std::string& scene_path,
                             const std::string& sweep_dir, const std::string& models_dir, PipelineLog log)
    : settings_(settings), models_dir_(models_dir), log_(std::move(log)), runner_(scene_path, settings.selection) {
  const Scene& scene = runner_.scene();
  if (scene.design.names.empty()) throw std::runtime_error(scene_path + ": the scene has no [design]");
  say("reading the runs in " + sweep_dir);
  TrainingData all = load_training_data({sweep_dir}, {}, training_fields(settings.training));
  const auto held_out = mpmrom::validation_runs(scene, settings.validation_runs);
  const auto design_runs = scene.design.all_runs();
  for (std::size_t i = 0; i < all.train.runs.size(); ++i) {
    const auto values = run_values(all.train.runs[i], scene.design.names);
    bool validation = false;
    for (std::size_t r : held_out) validation = validation || design_runs[r] == values;
    RunSet& set = validation ? validation_ : fit_.train;
    set.files.push_back(all.train.files[i]);
    set.runs.push_back(std::move(all.train.runs[i]));
  }
  fit_.test = std::move(all.test);
  if (validation_.runs.empty() || fit_.test.runs.empty())
    throw std::runtime_error(sweep_dir + ": the pipeline needs validation and test runs");
  say(std::to_string(fit_.train.runs.size()) + " training runs, " + std::to_string(validation_.runs.size()) +
      " validation runs (held out to choose models), " + std::to_string(fit_.test.runs.size()) + " test runs");
}

std::vector<RomConfiguration> PipelineStudy::configurations_per_network() const {
  std::vector<RomConfiguration> list;
  for (RomMethod method : settings_.methods)
    for (double cfl : settings_.rom_cfls)
      for (int samples : settings_.samples) list.push_back({method, samples, cfl});
  return list;
}

void PipelineStudy::open(const NetworkShape& shape) {
  if (models_.contains(shape.name())) return;
  const Model model = trained(shape);
  for (const auto& configuration : configurations_per_network()) evaluate(model, shape, configuration);
}

std::string PipelineStudy::model_path(const NetworkShape& shape) const {
  return (fs::path(models_dir_) / (shape.name() + ".h5")).string();
}

json PipelineStudy::batch_throughput(const NetworkShape& shape, const RomConfiguration& configuration) {
  const Scene& scene = runner_.scene();
  const Model model = load_model(model_path(shape));
  RomSettings rom = rom_settings(configuration);
  rom.end_time =
      settings_.batch_end_time > 0 ? settings_.batch_end_time : 4 * scene.end_time / std::max(1, scene.num_outputs);
  const auto reduction = runner_.hyper_reduction(model, rom, &fit_, log_);
  json points = json::array();
  for (int batch : settings_.batch_sizes) {
    std::vector<RolloutCase> cases;
    for (int b = 0; b < batch; ++b)
      cases.push_back({run_values(fit_.test.runs[std::size_t(b) % fit_.test.runs.size()], scene.design.names), "test"});
    const auto result = runner_.rollouts(model, runner_.scene_path(), cases, rom, reduction);
    const double rate = result.step_seconds > 0 ? double(result.steps) * batch / result.step_seconds : 0;
    points.push_back({{"batch", batch},
                      {"steps", result.steps},
                      {"rom_step_seconds", result.steps > 0 ? result.step_seconds / result.steps : 0.0},
                      {"rom_rollout_steps_per_s", rate}});
    say("batch " + std::to_string(batch) + ": " + general(rate) + " rollout-steps/s");
  }
  return {{"network", shape.name()},
          {"configuration", configuration.name()},
          {"end_time", rom.end_time},
          {"points", points}};
}

double PipelineStudy::parameters(const NetworkShape& s) {
  return double(nn::MlpLayout::make(s.latent_dim, s.width, s.depth).num_params);
}

RomSettings PipelineStudy::rom_settings(const RomConfiguration& configuration) const {
  RomSettings rom = runner_.rom_settings(configuration.method, configuration.samples, configuration.cfl);
  rom.validate();
  return rom;
}

Model PipelineStudy::trained(const NetworkShape& shape) {
  TrainingSettings training = settings_.training;
  training.latent_dim = shape.latent_dim;
  training.width = shape.width;
  training.depth = shape.depth;
  training.validate();
  const std::string path = model_path(shape), history_path = path + ".history.json";
  fs::create_directories(models_dir_);
  json history = json::array();
  Model model;
  if (fs::exists(path)) {
    model = load_model(path);
    if (model.settings == training.to_json() && model.runs.size() == fit_.train.runs.size()) {
      say("network " + shape.name() + ": reusing " + path);
      if (model.sample_ranking.empty() || model.projection_samples.empty()) {  // written before these were stored
        if (model.sample_ranking.empty()) model.sample_ranking = rank_samples_greedily(model, fit_, ranked_samples);
        if (model.projection_samples.empty())
          store_projection_samples(model, runner_.scene(), runner_.default_selector(model),
                                   std::size_t(RomSettings{}.samples), log_);
        save_model(path, model);
      }
      if (fs::exists(history_path)) std::ifstream(history_path) >> history;
      record_model(shape, model, history, path);
      return model;
    }
    say("network " + shape.name() + ": " + path + " was trained with other settings; training again");
  }
  say("network " + shape.name() + ": training (" + std::to_string(training.epochs) + " epochs)");
  TrainingCallbacks callbacks;
  callbacks.progress = [&](const TrainingProgress& p) {
    json entry = {{"epoch", p.epoch}, {"loss", p.train.total}, {"seconds", p.seconds}};
    if (p.validated) entry["validation_loss"] = p.validation.total;
    history.push_back(entry);
    if (p.validated || p.epoch == p.epochs)
      say("  epoch " + std::to_string(p.epoch) + "/" + std::to_string(p.epochs) + "  loss " + general(p.train.total) +
          (p.validated ? "  validation " + general(p.validation.total) : "") + "  " + general(p.seconds_left, 2) +
          " s left");
  };
  const std::string checkpoint = path + ".ckpt";
  model = train_model(fit_, training, checkpoint, fs::exists(checkpoint), callbacks);
  model.sample_ranking = rank_samples_greedily(model, fit_, ranked_samples);
  store_projection_samples(model, runner_.scene(), runner_.default_selector(model), std::size_t(RomSettings{}.samples),
                           log_);
  save_model(path, model);
  write_file_atomically(history_path, history.dump());
  std::error_code ignored;
  fs::remove(checkpoint, ignored);
  record_model(shape, model, history, path);
  return model;
}

void PipelineStudy::record_model(const NetworkShape& shape, const Model& model, const json& history,
                                 const std::string& path) {
  json entry = {{"network", shape.name()},
                {"latent_dim", shape.latent_dim},
                {"width", shape.width},
                {"depth", shape.depth},
                {"parameters", parameters(shape)},
                {"path", fs::relative(path, fs::path(models_dir_).parent_path()).string()},
                {"errors", model.errors},
                {"loss_history", history}};
  models_[shape.name()] = entry;
}

void PipelineStudy::evaluate(const Model& model, const NetworkShape& shape, const RomConfiguration& configuration) {
  const RomSettings rom = rom_settings(configuration);
  const auto reduction = runner_.hyper_reduction(model, rom, &fit_, log_);
  std::vector<RolloutCase> cases;
  std::vector<const Snapshot*> runs;
  for (const auto& run : validation_.runs) {
    cases.push_back({run_values(run, runner_.names()), "validation"});
    runs.push_back(&run);
  }
  for (const auto& run : fit_.test.runs) {
    cases.push_back({run_values(run, runner_.names()), "test"});
    runs.push_back(&run);
  }
  const auto result = runner_.rollouts(model, runner_.scene_path(), cases, rom, reduction);
  const std::size_t frames = result.times.size(), r = std::size_t(result.latent_dim);
  ErrorAccumulator validation, test, test_reference;
  int failures = 0;
  std::string failure;
  for (std::size_t b = 0; b < cases.size(); ++b) {
    if (!result.outcomes[b].message.empty()) {
      ++failures;
      failure = result.outcomes[b].message;
      continue;
    }
    const std::vector<double> xhat(result.xhat.begin() + b * frames * r, result.xhat.begin() + (b + 1) * frames * r);
    const std::vector<double> xhatdot(result.xhatdot.begin() + b * frames * r,
                                      result.xhatdot.begin() + (b + 1) * frames * r);
    const auto errors = rollout_errors(model, *runs[b], xhat, xhatdot);
    (cases[b].split == "validation" ? validation : test).merge(errors);
    const std::size_t t = b - validation_.runs.size();
    if (cases[b].split == "test" && t < references_.size())
      test_reference.merge(rollout_errors(model, references_[t], xhat, xhatdot));
  }
  const double simulated = result.times.back() - result.times.front();
  const double cost = result.step_seconds / (double(cases.size()) * simulated);
  json entry = {{"network", shape.name()},
                {"network_parameters", parameters(shape)},
                {"configuration", configuration.name()},
                {"method", to_string(configuration.method)},
                {"samples", configuration.samples},
                {"cfl", configuration.cfl > 0 ? configuration.cfl : runner_.scene().cfl},
                {"hyper_reduction", reduction.summary()},
                {"evaluated_points", result.evaluated_points},
                {"rollouts", cases.size()},
                {"steps", result.steps},
                {"rom_seconds_per_rollout_step", result.step_seconds / (double(result.steps) * cases.size())},
                {"cost_seconds_per_simulated_second", cost},
                {"validation", metrics_json(validation)},
                {"test", metrics_json(test)}};
  if (!references_.empty()) entry["test_vs_reference"] = metrics_json(test_reference);
  if (failures > 0) {
    // a failed rollout disqualifies the configuration: its errors cannot be measured over the whole horizon
    for (const char* split : {"validation", "test", "test_vs_reference"})
      if (entry.contains(split))
        for (auto& [key, value] : entry[split].items()) value = std::numeric_limits<double>::infinity();
    entry["failed_rollouts"] = failures;
    entry["failure"] = failure;
  }
  say("  " + shape.name() + " " + configuration.name() + ": " + std::to_string(result.steps) + " steps, " +
      general(cost) + " s per simulated second, validation " +
      percent(entry["validation"]["position_error"], "failed") + ", test " +
      percent(entry["test"]["position_error"], "failed") + (failures ? ", " + failure : ""));
  configurations_.push_back(entry);
}

}  // namespace mpmrom
