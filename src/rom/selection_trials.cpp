// The greedy projection's trial sets: the greedy error of a few samples does not tell which set holds the motion
// (docs/results/rom/README.md "Trial sets"), their rollouts over the training runs do, at the cost of one
// hyper-reduced batch a set.
#include "rom/detail/selection_trials.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "rom/detail/rollout_driver.hpp"
#include "rom/detail/snapshots.hpp"
#include "rom/kernels/projection.hpp"  // fatal_flags

namespace mpmrom::impl {

double training_rollout_error(const Model& model, const Scene& scene, const RomSettings& settings,
                              const CubatureFit& fit) {
  std::vector<int> indices;
  const std::vector<RolloutCase> cases = trained_cases(model, scene, std::size_t(settings.cubature_runs), indices);
  RomSettings rolled = settings;
  rolled.end_time = 0;  // the training runs' horizon
  HyperReduction reduction = build_hyper_reduction(model, scene, rolled, fit.samples);
  if (fitted_weights(settings) == SampleWeighting::Cubature) reduction.weights = fit.weights;
  auto stepper = create_stepper(model, scene.source_path, scene.design.names, cases, rolled, reduction);
  const std::size_t r = std::size_t(model.latent_dim), runs = cases.size();
  std::vector<std::vector<std::size_t>> codes;
  for (const int index : indices) codes.push_back(codes_of_run(model, index));
  // Each frame's rollout codes and the model's, side by side, decoded together at the end.
  std::vector<double> rolled_codes, own_codes;
  while (stepper->advance_frame()) {
    const BatchState state = stepper->state();
    for (std::size_t b = 0; b < runs; ++b) {
      if (stepper->flags(int(b)) & rom::fatal_flags) return std::numeric_limits<double>::infinity();
      if (std::size_t(state.frame) >= codes[b].size())
        throw std::runtime_error("trial sets: the model holds fewer codes of a training run than its frames");
      const double* code = state.xhat.data() + b * r;
      rolled_codes.insert(rolled_codes.end(), code, code + r);
      const double* own = &model.codes[codes[b][std::size_t(state.frame)] * r];
      own_codes.insert(own_codes.end(), own, own + r);
    }
  }
  const Candidates at = all_candidates(model, std::size_t(settings.cubature_candidates));
  std::vector<double> X;
  for (const int p : at.points)
    X.insert(X.end(), model.X.data() + std::size_t(p) * 3, model.X.data() + std::size_t(p) * 3 + 3);
  const std::vector<double> rates(rolled_codes.size(), 0.0);
  const std::vector<double> x = decode(model, X, rolled_codes, rates).x, y = decode(model, X, own_codes, rates).x;
  const std::size_t n = at.points.size(), count = rolled_codes.size() / r;
  double misfit = 0, displacement = 0;
  for (std::size_t c = 0; c < count; ++c)
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t d = 0; d < 3; ++d) {
        const std::size_t k = (c * n + i) * 3 + d;
        misfit += at.masses[i] * (x[k] - y[k]) * (x[k] - y[k]);
        displacement += at.masses[i] * (y[k] - X[i * 3 + d]) * (y[k] - X[i * 3 + d]);
      }
  return displacement > 0 ? std::sqrt(misfit / displacement) : std::sqrt(misfit);
}

namespace {

// Whether the model holds a code at each of the scene's output frames of some of its training runs: what the trial
// sets' rollouts are scored against (a model trained on a sweep of other output times or runs holds none).
bool holds_training_codes(const Model& model, const Scene& scene, std::size_t runs) {
  std::vector<int> indices;
  try {
    trained_cases(model, scene, runs, indices);
  } catch (const std::runtime_error&) {
    return false;
  }
  for (const int index : indices)
    if (codes_of_run(model, index).size() != std::size_t(scene.num_outputs) + 1) return false;
  return true;
}

}  // namespace

CubatureFit tried_projection_set(const Model& model, const Scene& scene, const RomSettings& settings,
                                 const ProjectionSelector& selector, bool fit,
                                 const std::function<void(const std::string&)>& log) {
  const std::vector<double>& weights = settings.selection_sensitivities;
  const std::size_t count = std::size_t(settings.samples);
  if (weights.size() == 1) return selector.select(count, fit, weights[0]);
  if (!holds_training_codes(model, scene, std::size_t(settings.cubature_runs))) {
    if (log)
      log("greedy projection: the model holds no codes of the scene's training runs at its output times, so its " +
          std::to_string(weights.size()) + " trial sets cannot be rolled out against them: kept the first");
    return selector.select(count, fit, weights[0]);
  }
  std::vector<CubatureFit> sets;
  std::vector<double> errors;
  std::string line = "greedy projection: " + std::to_string(weights.size()) +
                     " trial sets, their rollouts over the training runs off the model's codes by";
  std::size_t best = 0;
  for (std::size_t k = 0; k < weights.size(); ++k) {
    sets.push_back(selector.select(count, fit, weights[k]));
    double error = std::numeric_limits<double>::quiet_NaN();
    for (std::size_t j = 0; j < k && std::isnan(error); ++j)  // an identical set rolls out the same
      if (sets[j].samples == sets[k].samples && sets[j].weights == sets[k].weights) error = errors[j];
    if (std::isnan(error)) error = training_rollout_error(model, scene, settings, sets[k]);
    errors.push_back(error);
    if (error < errors[best]) best = k;
    char part[96];
    std::snprintf(part, sizeof part, "%s %.3g %% (sensitivity %g)", k == 0 ? "" : ",", 100 * error, weights[k]);
    line += part;
  }
  char chose[64];
  std::snprintf(chose, sizeof chose, ": chose sensitivity %g", weights[best]);
  if (log) log(line + chose);
  return sets[best];
}

}  // namespace mpmrom::impl
