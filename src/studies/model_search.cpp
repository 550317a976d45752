// The search for the cheapest reduced model that meets a target error (--target-error): the networks it tries,
// their names, the search itself and `mpmrom train --target-error` (search_model).
#include <algorithm>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "studies/detail/format.hpp"
#include "studies/detail/pipeline_study.hpp"
#include "studies/pipeline.hpp"

namespace mpmrom {

using nlohmann::json;

std::string NetworkShape::name() const {
  return "r" + std::to_string(latent_dim) + "_w" + std::to_string(width) + "_d" + std::to_string(depth);
}

NetworkShape NetworkShape::parse(const std::string& text) {
  NetworkShape shape;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%dx%dx%d%c", &shape.latent_dim, &shape.width, &shape.depth, &tail) != 3 ||
      shape.latent_dim < 1 || shape.width < 1 || shape.depth < 2)
    throw std::invalid_argument("network '" + text + "': expected r x width x depth, e.g. 5x48x5 (depth >= 2)");
  return shape;
}

std::string RomConfiguration::name() const {
  char cfl_text[32];
  std::snprintf(cfl_text, sizeof cfl_text, "%g", cfl);
  return to_string(method) + "_s" + std::to_string(samples) + "_cfl" + cfl_text;
}

std::vector<NetworkShape> default_search_networks(int depth) {
  std::vector<NetworkShape> networks;
  for (int width : {16, 32, 48})
    for (int r : {3, 5, 8}) networks.push_back({r, width, depth});
  return networks;
}

json PipelineStudy::search(double target, const std::vector<NetworkShape>& networks) {
  std::vector<NetworkShape> order = networks;
  std::stable_sort(order.begin(), order.end(),
                   [](const NetworkShape& a, const NetworkShape& b) { return parameters(a) < parameters(b); });
  json skipped = json::array();
  const auto best_meeting = [&]() -> const json* {
    const json* best = nullptr;
    for (const auto& c : configurations_)
      if (c["validation"]["position_error"].get<double>() <= target &&
          (!best || c["cost_seconds_per_simulated_second"] < (*best)["cost_seconds_per_simulated_second"]))
        best = &c;
    return best;
  };
  for (const auto& shape : order) {
    const json* best = best_meeting();
    if (best && !is_open(shape)) {
      const double predicted = predicted_cost(shape);
      if (predicted >= (*best)["cost_seconds_per_simulated_second"].get<double>()) {
        skipped.push_back({{"network", shape.name()}, {"predicted_cost_seconds_per_simulated_second", predicted}});
        continue;
      }
    }
    open(shape);
  }
  json decision = {{"target_position_error", target}, {"skipped_networks", skipped}};
  int evaluated = 0;
  for (const auto& shape : order) evaluated += is_open(shape);
  const json* best = best_meeting();
  if (!best) {
    decision["chosen"] = nullptr;
    decision["why"] = "no configuration of the " + std::to_string(evaluated) +
                      " trained networks meets a validation position error of " + percent(target, "failed");
    return decision;
  }
  decision["chosen"] = *best;
  std::ostringstream why;
  why << "the cheapest (" << general((*best)["cost_seconds_per_simulated_second"].get<double>())
      << " s per simulated second per rollout) of the configurations with validation position error <= "
      << percent(target, "failed") << ": " << evaluated << " of " << order.size()
      << " networks trained and evaluated in every configuration";
  if (!skipped.empty())
    why << "; " << skipped.size() << " larger networks skipped, their predicted cost (measured cost on a smaller "
        << "network scaled by the parameter count) not below the choice's";
  decision["why"] = why.str();
  return decision;
}

json PipelineStudy::search_targets(const std::vector<double>& targets, const std::vector<NetworkShape>& networks) {
  json decisions = json::array();
  for (double target : targets) {
    say("search: the cheapest configuration with validation position error <= " + percent(target, "failed"));
    decisions.push_back(search(target, networks));
    say("search: " + decisions.back()["why"].get<std::string>());
  }
  return decisions;
}

// The cheapest measured cost of any configuration, on the largest network evaluated so far that is smaller than
// this one, scaled by the ratio of parameter counts (the network's share of the work).
double PipelineStudy::predicted_cost(const NetworkShape& shape) const {
  double cost = std::numeric_limits<double>::infinity(), basis = 0;
  for (const auto& c : configurations_) {
    const double p = c["network_parameters"].get<double>();
    if (p > parameters(shape)) continue;
    if (p > basis) {
      basis = p;
      cost = std::numeric_limits<double>::infinity();
    }
    if (p == basis) cost = std::min(cost, c["cost_seconds_per_simulated_second"].get<double>());
  }
  return basis > 0 ? cost * parameters(shape) / basis : 0.0;
}

json search_model(const std::string& scene_path, const std::string& sweep_dir, const std::string& work_dir,
                  const std::string& model_path, const PipelineSettings& settings, const PipelineLog& log) {
  PipelineStudy study(settings, scene_path, sweep_dir, work_dir, log);
  const std::vector<NetworkShape> networks =
      settings.networks.empty() ? default_search_networks(settings.training.depth) : settings.networks;
  const json decisions = study.search_targets(settings.target_errors, networks);
  if (decisions.empty()) throw std::invalid_argument("search_model needs at least one target error");
  const json& first = decisions[0];
  if (first["chosen"].is_null()) throw std::runtime_error(first["why"].get<std::string>());
  const auto& m = study.models()[first["chosen"]["network"].get<std::string>()];
  save_model(model_path,
             load_model(study.model_path({m["latent_dim"].get<int>(), m["width"].get<int>(), m["depth"].get<int>()})));
  return {{"targets", decisions}, {"models", study.models()}, {"model", model_path}};
}

}  // namespace mpmrom
