// The pipeline's study (run_pipeline, search_model): the scene's runs split for training, validation and test, the
// trained networks and every evaluated reduced configuration.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "snapshots/metrics.hpp"
#include "studies/detail/study_runner.hpp"
#include "studies/pipeline.hpp"

namespace mpmrom {

// A run's values of the design parameters, in the order of names.
std::vector<double> run_values(const Snapshot& run, const std::vector<std::string>& names);

nlohmann::json metrics_json(const ErrorAccumulator& errors);

class PipelineStudy {
 public:
  PipelineStudy(const PipelineSettings& settings, const std::string& scene_path, const std::string& sweep_dir,
                const std::string& models_dir, PipelineLog log);

  const Scene& scene() const { return runner_.scene(); }
  const RunSet& test_runs() const { return fit_.test; }
  const RunSet& validation_runs() const { return validation_; }
  std::size_t training_runs() const { return fit_.train.runs.size(); }
  void set_references(std::vector<Snapshot> references) { references_ = std::move(references); }
  const nlohmann::json& models() const { return models_; }
  const std::vector<nlohmann::json>& configurations() const { return configurations_; }
  void say(const std::string& text) const {
    if (log_) log_(text);
  }

  // Trains the network (or loads it, trained before with the same settings) and evaluates every configuration on
  // it, once.
  void open(const NetworkShape& shape);
  bool is_open(const NetworkShape& shape) const { return models_.contains(shape.name()); }
  std::string model_path(const NetworkShape& shape) const;

  // The cheapest configuration whose validation position error meets the target, searching networks in order of
  // size and training one only while its predicted cost can still beat the best found (model_search.cpp).
  nlohmann::json search(double target, const std::vector<NetworkShape>& networks);
  // The decisions of search for each target in turn (an array), each announced in the log.
  nlohmann::json search_targets(const std::vector<double>& targets, const std::vector<NetworkShape>& networks);

  // Rollout-steps per second of one configuration as the batch grows (the test cases repeated).
  nlohmann::json batch_throughput(const NetworkShape& shape, const RomConfiguration& configuration);

 private:
  static double parameters(const NetworkShape& s);
  double predicted_cost(const NetworkShape& shape) const;
  std::vector<RomConfiguration> configurations_per_network() const;
  RomSettings rom_settings(const RomConfiguration& configuration) const;
  Model trained(const NetworkShape& shape);
  void record_model(const NetworkShape& shape, const Model& model, const nlohmann::json& history,
                    const std::string& path);
  void evaluate(const Model& model, const NetworkShape& shape, const RomConfiguration& configuration);

  PipelineSettings settings_;
  std::string models_dir_;
  PipelineLog log_;
  StudyRunner runner_;
  TrainingData fit_;
  RunSet validation_;
  std::vector<Snapshot> references_;
  nlohmann::json models_ = nlohmann::json::object();
  std::vector<nlohmann::json> configurations_;
};

}  // namespace mpmrom
