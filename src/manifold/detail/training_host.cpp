// The host-side steps of train_model (manifold/detail/training_host.hpp): no device kernels, which stay in trainer.cpp.
#include "manifold/detail/training_host.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

#include "core/math/splitmix64.hpp"
#include "manifold/detail/pca.hpp"

namespace mpmrom::impl {
namespace {

// Mean and scale of each coordinate over a set of 3-vectors; a coordinate that hardly varies gets the largest scale
// (it carries no information to standardise, and a tiny scale would amplify noise).
void mean_and_scale(const std::vector<double>& values, double mean[3], double scale[3]) {
  const std::size_t n = values.size() / 3;
  double sq[3] = {0, 0, 0};
  for (int d = 0; d < 3; ++d) mean[d] = 0;
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) mean[d] += values[3 * i + d] / double(n);
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) sq[d] += (values[3 * i + d] - mean[d]) * (values[3 * i + d] - mean[d]) / double(n);
  const double largest = std::sqrt(std::max({sq[0], sq[1], sq[2]}));
  for (int d = 0; d < 3; ++d) {
    const double s = std::sqrt(sq[d]);
    scale[d] = s > 1e-3 * largest ? s : largest;
  }
}

}  // namespace

void TrainingTargets::CF(std::size_t s, std::size_t p, double out[9]) const {
  const std::size_t e = snapshots[s].frame * points + p;
  const double *C = snapshots[s].run->C.data() + 9 * e, *F = snapshots[s].run->F.data() + 9 * e;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double sum = 0;
      for (int k = 0; k < 3; ++k) sum += C[3 * i + k] * F[3 * k + j];
      out[3 * i + j] = sum;
    }
}

std::uint64_t epoch_seed(std::uint64_t seed, std::uint64_t epoch) {
  return splitmix64_mix(seed * 0x9E3779B97F4A7C15ull + epoch + 0x632BE59BD9B4E019ull);
}

Model start_model(const TrainingData& data, const TrainingSettings& settings, TrainingTargets& targets) {
  const auto& runs = data.train.runs;
  const Snapshot& first = runs.front();
  Model model;
  model.latent_dim = settings.latent_dim;
  model.width = settings.width;
  model.depth = settings.depth;
  model.runs = data.train.files;
  // Runs read at some of the points (load_training_data's max_points): the model keeps every point's reference.
  const bool subset = !data.reference.X.empty();
  model.X = subset ? data.reference.X : first.X;
  model.mass = subset ? data.reference.mass : first.mass;
  model.volume = subset ? data.reference.volume : first.volume;
  model.scene_name = first.header.scene_name;
  model.scene_text = first.header.scene_text;
  model.settings = settings.to_json();
  for (std::size_t run = 0; run < runs.size(); ++run) {
    targets.stencil.add_run(runs[run].time, int(model.code_time.size()), starts_at_rest(runs[run]));
    for (std::size_t f = 0; f < runs[run].num_frames; ++f) {
      model.code_run.push_back(std::int64_t(run));
      model.code_time.push_back(runs[run].time[f]);
    }
    if (settings.lambda_affine > 0 && runs[run].C.size() != runs[run].F.size())
      throw std::runtime_error("--lambda-affine needs the runs' APIC matrices C (not loaded)");
    for (std::size_t f = 0; f < runs[run].num_frames; ++f) targets.snapshots.push_back({&runs[run], f});
  }
  targets.points = first.num_points;
  targets.X = first.X;
  targets.affine = settings.lambda_affine > 0;
  return model;
}

PointSplit split_points(const TrainingSettings& settings, int P) {
  std::vector<int> order(P);
  std::iota(order.begin(), order.end(), 0);
  std::mt19937_64 split_rng(epoch_seed(settings.seed, ~0ull));
  std::shuffle(order.begin(), order.end(), split_rng);
  const int num_validation = int(settings.validation_fraction * P);
  PointSplit split;
  split.validation.assign(order.begin(), order.begin() + num_validation);
  split.training.assign(order.begin() + num_validation, order.end());
  std::sort(split.validation.begin(), split.validation.end());
  std::sort(split.training.begin(), split.training.end());
  return split;
}

void set_scales(Model& model, const TrainingTargets& targets, const std::vector<int>& training_points) {
  const int S = int(model.code_time.size());
  std::vector<double> displacement;
  displacement.reserve(std::size_t(S) * training_points.size() * 3);
  double sum_u2 = 0, sum_strain2 = 0, sum_v2 = 0, sum_CF2 = 0;
  for (int s = 0; s < S; ++s) {
    const double *x = targets.x(std::size_t(s)), *F = targets.F(std::size_t(s)), *v = targets.v(std::size_t(s));
    for (const int p : training_points) {
      if (targets.affine) {
        double CF[9];
        targets.CF(std::size_t(s), std::size_t(p), CF);
        for (int i = 0; i < 9; ++i) sum_CF2 += CF[i] * CF[i];
      }
      for (int d = 0; d < 3; ++d) {
        const double u = x[std::size_t(p) * 3 + d] - targets.X[3 * std::size_t(p) + d];
        displacement.push_back(u);
        sum_u2 += u * u;
        const double vel = v[std::size_t(p) * 3 + d];
        sum_v2 += vel * vel;
      }
      for (int i = 0; i < 9; ++i) {
        const double e = F[std::size_t(p) * 9 + i] - (i % 4 == 0 ? 1.0 : 0.0);
        sum_strain2 += e * e;
      }
    }
  }
  const double samples = double(S) * double(training_points.size());
  if (!(sum_u2 > 0)) throw std::runtime_error("the training runs do not move: nothing to learn");
  model.loss_scales[0] = std::sqrt(sum_u2 / (3 * samples));
  model.loss_scales[1] = sum_strain2 > 0 ? std::sqrt(sum_strain2 / (9 * samples)) : 1.0;
  model.loss_scales[2] = sum_v2 > 0 ? std::sqrt(sum_v2 / (3 * samples)) : 1.0;
  model.loss_scales[3] = sum_CF2 > 0 ? std::sqrt(sum_CF2 / (9 * samples)) : 1.0;
  mean_and_scale(model.X, model.standardization.input_mean, model.standardization.input_scale);
  mean_and_scale(displacement, model.standardization.output_mean, model.standardization.output_scale);
}

void set_initial_parameters(Model& model, const TrainingSettings& settings, const TrainingTargets& targets,
                            const std::vector<int>& training_points) {
  const int S = int(model.code_time.size());
  const nn::MlpLayout layout = model.layout();
  std::mt19937_64 init_rng(epoch_seed(settings.seed, ~1ull));
  model.weights.assign(layout.num_params, 0.0);
  for (int l = 0; l < layout.num_layers; ++l) {
    const double bound = std::sqrt(3.0 / layout.dims[l]);
    std::uniform_real_distribution<double> uniform(-bound, bound);
    for (int i = 0; i < layout.dims[l + 1] * layout.dims[l]; ++i)
      model.weights[layout.weight_offset[l] + i] = uniform(init_rng);
  }
  const std::size_t stride = std::max<std::size_t>(1, training_points.size() / 2048);
  std::vector<int> pca_points;
  for (std::size_t i = 0; i < training_points.size(); i += stride) pca_points.push_back(training_points[i]);
  std::vector<double> rows(std::size_t(S) * pca_points.size() * 3);
  for (int s = 0; s < S; ++s)
    for (std::size_t i = 0; i < pca_points.size(); ++i)
      for (int d = 0; d < 3; ++d)
        rows[(std::size_t(s) * pca_points.size() + i) * 3 + d] =
            targets.x(std::size_t(s))[std::size_t(pca_points[i]) * 3 + d] -
            targets.X[3 * std::size_t(pca_points[i]) + d];
  model.codes = principal_coordinates(rows, S, pca_points.size() * 3, settings.latent_dim);
}

void resume_from(const std::string& checkpoint_path, Model& model, OptimizerState& optimizer) {
  OptimizerState saved;
  const Model checkpoint = load_model(checkpoint_path, &saved);
  if (checkpoint.settings != model.settings)
    throw std::runtime_error(checkpoint_path + ": checkpoint was written with other training settings (" +
                             checkpoint.settings.dump() + ")");
  if (checkpoint.runs != model.runs || checkpoint.code_time != model.code_time)
    throw std::runtime_error(checkpoint_path + ": checkpoint was trained on other runs");
  model.weights = checkpoint.weights;
  model.codes = checkpoint.codes;
  model.standardization = checkpoint.standardization;
  std::copy(checkpoint.loss_scales, checkpoint.loss_scales + 4, model.loss_scales);
  optimizer = saved;
}

namespace {

void append(VelocityByFrame& all, const VelocityByFrame& run) {
  for (auto [to, from] : {std::pair{&all.time, &run.time},
                          {&all.rate_misfit, &run.rate_misfit},
                          {&all.tangent_misfit, &run.tangent_misfit},
                          {&all.norm, &run.norm}})
    to->insert(to->end(), from->begin(), from->end());
}

}  // namespace

void set_errors(Model& model, const TrainingData& data, const std::vector<int>& validation_points,
                const TrainingProgress& final, SteadyClock::time_point start, const TrainingCallbacks& callbacks) {
  const auto& runs = data.train.runs;
  const int r = model.latent_dim;
  say(callbacks, "evaluating the reconstruction errors");
  ErrorAccumulator train_all, train_validation, test_all;
  VelocityByFrame train_velocity, test_velocity;  // the runs' frames one after the other
  nlohmann::json test_runs = nlohmann::json::array();
  for (std::size_t run = 0, base = 0; run < runs.size(); base += runs[run].num_frames, ++run) {
    const std::vector<double> codes(model.codes.begin() + base * r,
                                    model.codes.begin() + (base + runs[run].num_frames) * r);
    const auto errors = reconstruction_errors(model, runs[run], codes);
    train_all.merge(errors.errors);
    append(train_velocity, errors.velocity);
    if (!validation_points.empty())
      train_validation.merge(reconstruction_errors(model, runs[run], codes, validation_points).errors);
  }
  for (std::size_t run = 0; run < data.test.runs.size(); ++run) {
    say(callbacks, "projecting test run " + data.test.files[run]);
    const auto codes = project_codes(model, data.test.runs[run]);
    const auto errors = reconstruction_errors(model, data.test.runs[run], codes);
    test_all.merge(errors.errors);
    append(test_velocity, errors.velocity);
    auto run_errors = to_json(errors.errors.metrics());
    run_errors["tangent_velocity_error"] = errors.velocity.tangent_velocity_error();
    run_errors["frames"] = errors.velocity.frames_json();
    test_runs.push_back({{"file", data.test.files[run]}, {"errors", run_errors}});
  }
  auto train_errors = to_json(train_all.metrics());
  train_errors["tangent_velocity_error"] = train_velocity.tangent_velocity_error();
  model.errors = {{"train", train_errors},
                  {"training_seconds", seconds_since(start)},
                  {"training_samples_per_s", final.samples_per_second},  // the epochs alone, validation included
                  {"final_loss", {{"train", final.train.total}, {"validation", final.validation.total}}}};
  if (!validation_points.empty()) model.errors["validation_points"] = to_json(train_validation.metrics());
  if (!data.test.runs.empty()) {
    model.errors["test"] = to_json(test_all.metrics());
    model.errors["test"]["tangent_velocity_error"] = test_velocity.tangent_velocity_error();
    model.errors["test_runs"] = test_runs;
  }
}

}  // namespace mpmrom::impl
