#include "manifold/trainer.hpp"

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <stdexcept>

#include "core/math/cholesky.hpp"
#include "manifold/nn/adam.hpp"
#include "manifold/nn/mlp.hpp"
#include "manifold/nn/mlp_train.hpp"
#include "mpmrom/mpmrom_config.hpp"
#include "manifold/bench_nn.hpp"
#include "manifold/device_data.hpp"
#include "manifold/detail/pca.hpp"

namespace mpmrom {
namespace {

using ExecutionSpace = Kokkos::DefaultExecutionSpace;
using MemorySpace = ExecutionSpace::memory_space;
using T = real_t;
using Vector = Kokkos::View<T*, MemorySpace>;
using Matrix = Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>;
using Cube = Kokkos::View<T***, Kokkos::LayoutRight, MemorySpace>;
using Quad = Kokkos::View<T****, Kokkos::LayoutRight, MemorySpace>;
using IndexVector = Kokkos::View<int*, MemorySpace>;
using Clock = std::chrono::steady_clock;
using impl::device_mlp;
using impl::download;
using impl::upload;
using impl::upload_indices;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Index lists sent to the device every minibatch, through one allocation made up front (a device allocation per
// step would cost more than the step on a GPU).
class IndexStaging {
 public:
  IndexStaging(const std::string& label, std::size_t capacity)
      : device_(label, capacity), host_(Kokkos::create_mirror_view(device_)) {}
  Kokkos::View<const int*, MemorySpace> upload(const std::vector<int>& values) {
    if (values.size() > device_.extent(0)) throw std::logic_error("IndexStaging: more indices than its capacity");
    std::copy(values.begin(), values.end(), host_.data());
    const auto range = Kokkos::make_pair(std::size_t(0), values.size());
    Kokkos::deep_copy(Kokkos::subview(device_, range), Kokkos::subview(host_, range));
    return Kokkos::subview(device_, range);
  }

 private:
  IndexVector device_;
  IndexVector::HostMirror host_;
};

// Data-parallel training: the ranks' minibatch gradients summed in place, through a host copy (the gradient is a
// few thousand values, one MPI_Allreduce a step).
class GradientSum {
 public:
  explicit GradientSum(const Vector& grad) : host_(Kokkos::create_mirror_view(grad)) {}
  void sum(const ExecutionSpace& space, const Vector& grad, const parallel::Communicator& comm) {
    Kokkos::deep_copy(space, host_, grad);
    space.fence();
    comm.sum(host_.data(), host_.size());
    Kokkos::deep_copy(space, grad, host_);
  }

 private:
  Vector::HostMirror host_;
};

void sum_over_ranks(const parallel::Communicator& comm, nn::LossTerms<double>& terms) {
  double values[3] = {terms.position, terms.gradient, terms.velocity};
  comm.sum(values, 3);
  terms = {values[0], values[1], values[2]};
}

// The finite-difference stencil of every snapshot's code rate: central inside a run, one-sided at its ends, zero
// for a run of one frame. Snapshots are numbered run after run, frame after frame, from `base`.
struct RateStencil {
  std::vector<int> from, to;
  std::vector<double> inv_dt;

  void add_run(const std::vector<double>& times, int base) {
    const int frames = int(times.size());
    for (int f = 0; f < frames; ++f) {
      const int lo = frames == 1 ? f : std::max(f - 1, 0);
      const int hi = frames == 1 ? f : std::min(f + 1, frames - 1);
      from.push_back(base + lo);
      to.push_back(base + hi);
      inv_dt.push_back(hi > lo ? 1.0 / (times[hi] - times[lo]) : 0.0);
    }
  }
  std::vector<double> rates(const std::vector<double>& codes, int r) const {
    std::vector<double> out(from.size() * r);
    for (std::size_t s = 0; s < from.size(); ++s)
      for (int q = 0; q < r; ++q) out[s * r + q] = (codes[to[s] * r + q] - codes[from[s] * r + q]) * inv_dt[s];
    return out;
  }
};

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

std::uint64_t epoch_seed(std::uint64_t seed, std::uint64_t epoch) {
  // splitmix64 of (seed, epoch): independent streams per epoch, so a resumed run draws what the original would have
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ull + epoch + 0x632BE59BD9B4E019ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// Device buffers of one minibatch shape, created on first use.
class BufferCache {
 public:
  BufferCache(const nn::MlpLayout& layout, nn::Channels channels) : layout_(layout), channels_(channels) {}
  nn::TrainingBuffers<T, MemorySpace>& get(int batch_snapshots, int per_snapshot) {
    auto& slot = cache_[{batch_snapshots, per_snapshot}];
    if (!slot)
      slot = std::make_unique<nn::TrainingBuffers<T, MemorySpace>>(ExecutionSpace(), layout_, channels_,
                                                                   batch_snapshots * per_snapshot, batch_snapshots);
    return *slot;
  }

 private:
  nn::MlpLayout layout_;
  nn::Channels channels_;
  std::map<std::pair<int, int>, std::unique_ptr<nn::TrainingBuffers<T, MemorySpace>>> cache_;
};

LossReport to_report(const nn::LossTerms<double>& sum, double samples, const TrainingSettings& s) {
  LossReport r;
  r.position = sum.position / samples;
  r.gradient = sum.gradient / samples;
  r.velocity = sum.velocity / samples;
  r.total = r.position + s.lambda_gradient * r.gradient + s.lambda_velocity * r.velocity;
  return r;
}

void accumulate(nn::LossTerms<double>& sum, const nn::LossTerms<T>& batch, int samples) {
  sum.position += double(batch.position) * samples;
  sum.gradient += double(batch.gradient) * samples;
  sum.velocity += double(batch.velocity) * samples;
}

}  // namespace

nlohmann::json TrainingSettings::to_json() const {
  return {{"latent_dim", latent_dim},
          {"width", width},
          {"depth", depth},
          {"lambda_gradient", lambda_gradient},
          {"lambda_velocity", lambda_velocity},
          {"epochs", epochs},
          {"batch_snapshots", batch_snapshots},
          {"points_per_snapshot", points_per_snapshot},
          {"learning_rate", learning_rate},
          {"final_learning_rate", final_learning_rate},
          {"validation_fraction", validation_fraction},
          {"validate_every", validate_every},
          {"seed", seed}};
}

TrainingSettings TrainingSettings::from_json(const nlohmann::json& j) {
  TrainingSettings s;
  s.latent_dim = j.at("latent_dim");
  s.width = j.at("width");
  s.depth = j.at("depth");
  s.lambda_gradient = j.at("lambda_gradient");
  s.lambda_velocity = j.at("lambda_velocity");
  s.epochs = j.at("epochs");
  s.batch_snapshots = j.at("batch_snapshots");
  s.points_per_snapshot = j.at("points_per_snapshot");
  s.learning_rate = j.at("learning_rate");
  s.final_learning_rate = j.at("final_learning_rate");
  s.validation_fraction = j.at("validation_fraction");
  s.validate_every = j.at("validate_every");
  s.seed = j.at("seed");
  return s;
}

void TrainingSettings::validate() const {
  nn::MlpLayout::make(latent_dim, width, depth);  // throws on a bad architecture
  auto require = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument(what);
  };
  require(std::isfinite(lambda_gradient) && lambda_gradient >= 0, "lambda-grad must be >= 0");
  require(std::isfinite(lambda_velocity) && lambda_velocity >= 0, "lambda-vel must be >= 0");
  require(epochs >= 1, "epochs must be >= 1");
  require(batch_snapshots >= 1, "batch-snapshots must be >= 1");
  require(points_per_snapshot >= 1, "points-per-snapshot must be >= 1");
  require(learning_rate > 0 && final_learning_rate > 0 && std::isfinite(learning_rate) &&
              std::isfinite(final_learning_rate),
          "learning rates must be positive");
  require(validation_fraction >= 0 && validation_fraction < 1, "validation fraction must be in [0, 1)");
  require(validate_every >= 0, "validate-every must be >= 0");
}

Model train_model(const TrainingData& data, const TrainingSettings& settings, const std::string& checkpoint_path,
                  bool resume, const TrainingCallbacks& callbacks, const parallel::Communicator& comm) {
  settings.validate();
  const auto say = [&](const std::string& text) {
    if (callbacks.message) callbacks.message(text);
  };
  const auto& runs = data.train.runs;
  const Snapshot& first = runs.front();
  const int P = int(first.num_points);
  const int r = settings.latent_dim;

  // Snapshots, their code-rate stencils, and targets.
  RateStencil stencil;
  Model model;
  model.latent_dim = r;
  model.width = settings.width;
  model.depth = settings.depth;
  model.runs = data.train.files;
  model.X = first.X;
  model.mass = first.mass;
  model.volume = first.volume;
  model.scene_name = first.header.scene_name;
  model.scene_text = first.header.scene_text;
  model.settings = settings.to_json();
  std::vector<double> x, F, v;
  for (std::size_t run = 0; run < runs.size(); ++run) {
    stencil.add_run(runs[run].time, int(model.code_time.size()));
    for (std::size_t f = 0; f < runs[run].num_frames; ++f) {
      model.code_run.push_back(std::int64_t(run));
      model.code_time.push_back(runs[run].time[f]);
    }
    x.insert(x.end(), runs[run].x.begin(), runs[run].x.end());
    F.insert(F.end(), runs[run].F.begin(), runs[run].F.end());
    v.insert(v.end(), runs[run].v.begin(), runs[run].v.end());
  }
  const int S = int(model.code_time.size());
  if (S < comm.size())
    throw std::runtime_error(std::to_string(S) + " training snapshots cannot be shared by " +
                             std::to_string(comm.size()) + " processes");
  // Data-parallel training: this rank's device holds the targets of its share of the snapshots (every rank holds
  // every weight and code), works on the samples of each minibatch that fall in its share, and the ranks sum their
  // gradients before the identical Adam steps.
  const auto share = parallel::share_of(std::size_t(S), comm.rank(), comm.size());
  const int first_owned = int(share.begin), num_owned = int(share.end - share.begin);

  // Validation points: a seeded random fraction of the material points, never trained on.
  std::vector<int> order(P);
  std::iota(order.begin(), order.end(), 0);
  std::mt19937_64 split_rng(epoch_seed(settings.seed, ~0ull));
  std::shuffle(order.begin(), order.end(), split_rng);
  const int num_validation = int(settings.validation_fraction * P);
  std::vector<int> validation_points(order.begin(), order.begin() + num_validation);
  std::vector<int> training_points(order.begin() + num_validation, order.end());
  std::sort(validation_points.begin(), validation_points.end());
  std::sort(training_points.begin(), training_points.end());

  // Standardisation and loss scales from the training points of every training snapshot.
  std::vector<double> displacement;
  displacement.reserve(std::size_t(S) * training_points.size() * 3);
  double sum_u2 = 0, sum_strain2 = 0, sum_v2 = 0;
  for (int s = 0; s < S; ++s)
    for (const int p : training_points) {
      for (int d = 0; d < 3; ++d) {
        const double u = x[(std::size_t(s) * P + p) * 3 + d] - first.X[3 * p + d];
        displacement.push_back(u);
        sum_u2 += u * u;
        const double vel = v[(std::size_t(s) * P + p) * 3 + d];
        sum_v2 += vel * vel;
      }
      for (int i = 0; i < 9; ++i) {
        const double e = F[(std::size_t(s) * P + p) * 9 + i] - (i % 4 == 0 ? 1.0 : 0.0);
        sum_strain2 += e * e;
      }
    }
  const double samples = double(S) * double(training_points.size());
  if (!(sum_u2 > 0)) throw std::runtime_error("the training runs do not move: nothing to learn");
  model.loss_scales[0] = std::sqrt(sum_u2 / (3 * samples));
  model.loss_scales[1] = sum_strain2 > 0 ? std::sqrt(sum_strain2 / (9 * samples)) : 1.0;
  model.loss_scales[2] = sum_v2 > 0 ? std::sqrt(sum_v2 / (3 * samples)) : 1.0;
  mean_and_scale(first.X, model.standardization.input_mean, model.standardization.input_scale);
  mean_and_scale(displacement, model.standardization.output_mean, model.standardization.output_scale);

  // Initial weights (LeCun-uniform, zero biases) and codes (leading principal coordinates of the displacements).
  const nn::MlpLayout layout = model.layout();
  std::mt19937_64 init_rng(epoch_seed(settings.seed, ~1ull));
  model.weights.assign(layout.num_params, 0.0);
  for (int l = 0; l < layout.num_layers; ++l) {
    const double bound = std::sqrt(3.0 / layout.dims[l]);
    std::uniform_real_distribution<double> uniform(-bound, bound);
    for (int i = 0; i < layout.dims[l + 1] * layout.dims[l]; ++i) model.weights[layout.weight_offset[l] + i] = uniform(init_rng);
  }
  {
    const std::size_t stride = std::max<std::size_t>(1, training_points.size() / 2048);
    std::vector<int> pca_points;
    for (std::size_t i = 0; i < training_points.size(); i += stride) pca_points.push_back(training_points[i]);
    std::vector<double> rows(std::size_t(S) * pca_points.size() * 3);
    for (int s = 0; s < S; ++s)
      for (std::size_t i = 0; i < pca_points.size(); ++i)
        for (int d = 0; d < 3; ++d)
          rows[(std::size_t(s) * pca_points.size() + i) * 3 + d] =
              x[(std::size_t(s) * P + pca_points[i]) * 3 + d] - first.X[3 * pca_points[i] + d];
    model.codes = principal_coordinates(rows, S, pca_points.size() * 3, r);
  }

  const int num_weights = layout.num_params;
  const int num_total = num_weights + S * r;
  OptimizerState optimizer;
  optimizer.first_moment.assign(num_total, 0.0);
  optimizer.second_moment.assign(num_total, 0.0);
  if (resume) {
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
    std::copy(checkpoint.loss_scales, checkpoint.loss_scales + 3, model.loss_scales);
    optimizer = saved;
    say("resuming from " + checkpoint_path + " after epoch " + std::to_string(optimizer.epoch));
  }

  // Device state: parameters = weights then codes; gradient; Adam moments; targets.
  std::vector<double> all_params = model.weights;
  all_params.insert(all_params.end(), model.codes.begin(), model.codes.end());
  Vector params = upload<Vector>("mpmrom::train::params", all_params, num_total);
  Vector grad("mpmrom::train::grad", num_total);
  Vector first_moment = upload<Vector>("mpmrom::train::adam_m", optimizer.first_moment, num_total);
  Vector second_moment = upload<Vector>("mpmrom::train::adam_v", optimizer.second_moment, num_total);
  const nn::Mlp<T, MemorySpace> mlp = device_mlp(model, params);

  nn::CodeTable<T, MemorySpace> table;
  table.code_offset = num_weights;
  table.latent_dim = r;
  table.rate_from = upload_indices("mpmrom::train::rate_from", stencil.from);
  table.rate_to = upload_indices("mpmrom::train::rate_to", stencil.to);
  table.rate_inv_dt = upload<Vector>("mpmrom::train::rate_inv_dt", stencil.inv_dt, S);

  nn::BatchSamples<T, MemorySpace> batch;
  batch.X = upload<Matrix>("mpmrom::train::X", first.X, P, 3);
  const auto owned_rows = [&](const std::vector<double>& all, std::size_t per_snapshot_values) {
    return std::vector<double>(all.begin() + long(first_owned * per_snapshot_values),
                               all.begin() + long((first_owned + num_owned) * per_snapshot_values));
  };
  batch.x = upload<Cube>("mpmrom::train::x", owned_rows(x, std::size_t(P) * 3), num_owned, P, 3);
  batch.F = upload<Cube>("mpmrom::train::F", owned_rows(F, std::size_t(P) * 9), num_owned, P, 9);
  batch.v = upload<Cube>("mpmrom::train::v", owned_rows(v, std::size_t(P) * 3), num_owned, P, 3);
  x.clear();
  F.clear();
  v.clear();

  nn::LossWeights<T> weights;
  weights.lambda_gradient = T(settings.lambda_gradient);
  weights.lambda_velocity = T(settings.lambda_velocity);
  weights.position_scale = T(model.loss_scales[0]);
  weights.gradient_scale = T(model.loss_scales[1]);
  weights.velocity_scale = T(model.loss_scales[2]);
  const nn::Channels channels = nn::Channels::make(settings.lambda_gradient > 0, settings.lambda_velocity > 0);
  BufferCache buffers(layout, channels);
  const ExecutionSpace space;

  const int per_snapshot = std::min<int>(settings.points_per_snapshot, int(training_points.size()));
  const int steps_per_epoch = (S + settings.batch_snapshots - 1) / settings.batch_snapshots;
  const long total_steps = long(steps_per_epoch) * settings.epochs;
  const int validate_every = settings.validate_every > 0 ? settings.validate_every
                                                         : std::max(1, settings.epochs / 20);

  // Host-side copies of the device state, for checkpoints and the final model.
  const auto snapshot_state = [&]() {
    const auto p = download(params);
    model.weights.assign(p.begin(), p.begin() + num_weights);
    model.codes.assign(p.begin() + num_weights, p.end());
    optimizer.first_moment = download(first_moment);
    optimizer.second_moment = download(second_moment);
  };

  // The loss reported during training uses at most 2048 of the held-out points, evenly spread: on 10^6-point scenes
  // every held-out point at every snapshot would cost more than the training itself. The final errors use them all.
  std::vector<int> monitor_points;
  const std::size_t monitor_stride = std::max<std::size_t>(1, (validation_points.size() + 2047) / 2048);
  for (std::size_t i = 0; i < validation_points.size(); i += monitor_stride)
    monitor_points.push_back(validation_points[i]);
  const int validation_group = std::max(1, 4096 / std::max(int(monitor_points.size()), 1));
  IndexStaging batch_snapshots("mpmrom::train::batch_snapshot",
                               std::size_t(std::max(settings.batch_snapshots, validation_group)));
  IndexStaging batch_rows("mpmrom::train::batch_row",
                          std::size_t(std::max(settings.batch_snapshots, validation_group)));
  IndexStaging batch_points("mpmrom::train::batch_point",
                            std::max(std::size_t(settings.batch_snapshots) * per_snapshot,
                                     std::size_t(validation_group) * monitor_points.size()));

  const auto validation_loss = [&]() {
    nn::LossTerms<double> sum;
    const int count = int(monitor_points.size());
    const int group = validation_group;
    for (int begin = 0; begin < num_owned; begin += group) {
      const int snaps = std::min(group, num_owned - begin);
      std::vector<int> snapshot_ids(snaps), rows(snaps), point_ids;
      for (int i = 0; i < snaps; ++i) {
        rows[i] = begin + i;
        snapshot_ids[i] = first_owned + begin + i;
        point_ids.insert(point_ids.end(), monitor_points.begin(), monitor_points.end());
      }
      batch.samples_per_snapshot = count;
      batch.total_samples = 0;
      batch.snapshot = batch_snapshots.upload(snapshot_ids);
      batch.row = batch_rows.upload(rows);
      batch.point = batch_points.upload(point_ids);
      const auto terms = nn::minibatch_loss(space, mlp, table, channels, weights, batch, buffers.get(snaps, count),
                                            Vector());
      accumulate(sum, terms, snaps * count);
    }
    sum_over_ranks(comm, sum);
    return to_report(sum, double(S) * count, settings);
  };

  GradientSum gradient_sum(grad);
  const auto start = Clock::now();
  auto last_checkpoint = start;
  long samples_done = 0;
  long step = optimizer.step;
  std::vector<int> pool = training_points;
  TrainingProgress final;
  for (int epoch = int(optimizer.epoch); epoch < settings.epochs; ++epoch) {
    std::mt19937_64 rng(epoch_seed(settings.seed, std::uint64_t(epoch)));
    std::vector<int> snapshot_order(S);
    std::iota(snapshot_order.begin(), snapshot_order.end(), 0);
    std::shuffle(snapshot_order.begin(), snapshot_order.end(), rng);
    pool = training_points;
    nn::LossTerms<double> epoch_sum;
    double epoch_samples = 0;
    double lr = 0;
    for (int k = 0; k < steps_per_epoch; ++k) {
      const int begin = k * settings.batch_snapshots;
      const int snaps = std::min(settings.batch_snapshots, S - begin);
      // Every rank draws the whole minibatch (the same random stream) and keeps the snapshots of its share.
      std::vector<int> snapshot_ids, rows, point_ids;
      point_ids.reserve(std::size_t(snaps) * per_snapshot);
      for (int i = 0; i < snaps; ++i) {
        const int snapshot = snapshot_order[std::size_t(begin + i)];
        const bool owned = snapshot >= first_owned && snapshot < first_owned + num_owned;
        if (owned) {
          snapshot_ids.push_back(snapshot);
          rows.push_back(snapshot - first_owned);
        }
        // a fresh partial Fisher-Yates draw of distinct points for each snapshot
        for (int j = 0; j < per_snapshot; ++j) {
          const std::size_t pick = j + std::size_t(rng() % (pool.size() - j));
          std::swap(pool[j], pool[pick]);
          if (owned) point_ids.push_back(pool[j]);
        }
      }
      nn::LossTerms<T> terms{0, 0, 0};
      const int owned_snaps = int(snapshot_ids.size());
      if (owned_snaps > 0) {
        batch.samples_per_snapshot = per_snapshot;
        batch.total_samples = long(snaps) * per_snapshot;
        batch.snapshot = batch_snapshots.upload(snapshot_ids);
        batch.row = batch_rows.upload(rows);
        batch.point = batch_points.upload(point_ids);
        terms = nn::minibatch_loss(space, mlp, table, channels, weights, batch, buffers.get(owned_snaps, per_snapshot),
                                   grad);
      } else {
        Kokkos::deep_copy(space, grad, T(0));
      }
      if (comm.size() > 1) gradient_sum.sum(space, grad, comm);
      ++step;
      const double progress = total_steps > 1 ? double(step - 1) / double(total_steps - 1) : 0.0;
      lr = settings.learning_rate * std::pow(settings.final_learning_rate / settings.learning_rate, progress);
      nn::adam_step(space, params, Kokkos::View<const T*, MemorySpace>(grad), first_moment, second_moment, 0,
                    num_total, lr, step);
      accumulate(epoch_sum, terms, snaps * per_snapshot);
      epoch_samples += double(snaps) * per_snapshot;
    }
    space.fence();
    sum_over_ranks(comm, epoch_sum);
    samples_done += long(epoch_samples);
    TrainingProgress progress;
    progress.epoch = epoch + 1;
    progress.epochs = settings.epochs;
    progress.train = to_report(epoch_sum, epoch_samples, settings);
    if (!std::isfinite(progress.train.total))
      throw std::runtime_error("training diverged at epoch " + std::to_string(epoch + 1) +
                               " (loss is not finite): lower --learning-rate");
    const bool last = epoch + 1 == settings.epochs;
    if (!validation_points.empty() && ((epoch + 1) % validate_every == 0 || last)) {
      progress.validated = true;
      progress.validation = validation_loss();
    }
    progress.learning_rate = lr;
    progress.seconds = seconds_since(start);
    progress.samples_per_second = samples_done / std::max(progress.seconds, 1e-9);
    progress.seconds_left = progress.seconds / (epoch + 1 - optimizer.epoch) * (settings.epochs - epoch - 1);
    if (callbacks.progress) callbacks.progress(progress);
    final = progress;

    // every rank asks (the ranks hold identical parameters; rank 0 writes)
    if (!checkpoint_path.empty() && !last &&
        comm.any(seconds_since(last_checkpoint) >= settings.checkpoint_seconds)) {
      if (comm.is_root()) {
        snapshot_state();
        OptimizerState state = optimizer;
        state.step = step;
        state.epoch = epoch + 1;
        save_model(checkpoint_path, model, &state);
        say("checkpoint after epoch " + std::to_string(epoch + 1) + " in " + checkpoint_path);
      }
      last_checkpoint = Clock::now();
    }
  }
  snapshot_state();
  if (!comm.is_root()) return model;  // rank 0 evaluates and writes the model

  // Errors: every training snapshot with its own code (all points, and the validation points alone), and the
  // test runs with projected codes.
  say("evaluating the reconstruction errors");
  ErrorAccumulator train_all, train_validation, test_all;
  nlohmann::json test_runs = nlohmann::json::array();
  for (std::size_t run = 0, base = 0; run < runs.size(); base += runs[run].num_frames, ++run) {
    const std::vector<double> codes(model.codes.begin() + base * r,
                                    model.codes.begin() + (base + runs[run].num_frames) * r);
    train_all.merge(reconstruction_errors(model, runs[run], codes));
    if (!validation_points.empty())
      train_validation.merge(reconstruction_errors(model, runs[run], codes, validation_points));
  }
  for (std::size_t run = 0; run < data.test.runs.size(); ++run) {
    say("projecting test run " + data.test.files[run]);
    const auto codes = project_codes(model, data.test.runs[run]);
    const auto errors = reconstruction_errors(model, data.test.runs[run], codes);
    test_all.merge(errors);
    test_runs.push_back({{"file", data.test.files[run]}, {"errors", to_json(errors.metrics())}});
  }
  model.errors = {{"train", to_json(train_all.metrics())},
                  {"training_seconds", seconds_since(start)},
                  {"training_samples_per_s", final.samples_per_second},  // the epochs alone, validation included
                  {"final_loss", {{"train", final.train.total}, {"validation", final.validation.total}}}};
  if (!validation_points.empty()) model.errors["validation_points"] = to_json(train_validation.metrics());
  if (!data.test.runs.empty()) {
    model.errors["test"] = to_json(test_all.metrics());
    model.errors["test_runs"] = test_runs;
  }
  return model;
}

std::vector<double> project_codes(const Model& model, const Snapshot& run) {
  const int r = model.latent_dim;
  const int P = int(run.num_points), frames = int(run.num_frames);
  if (run.num_points != model.num_points())
    throw std::runtime_error("run has " + std::to_string(run.num_points) + " points, the model was trained on " +
                             std::to_string(model.num_points()));
  const nn::MlpLayout layout = model.layout();
  const Vector weights = upload<Vector>("mpmrom::project::weights", model.weights, layout.num_params);
  const auto mlp = device_mlp(model, weights);
  const ExecutionSpace space;
  const Matrix X = upload<Matrix>("mpmrom::project::X", run.X, P, 3);

  // Start each frame from the training code that fits it best on a subset of points.
  std::vector<int> subset;
  for (int p = 0; p < P; p += std::max(1, P / 256)) subset.push_back(p);
  std::vector<double> X_subset;
  for (const int p : subset) X_subset.insert(X_subset.end(), run.X.begin() + 3 * p, run.X.begin() + 3 * p + 3);
  const int num_train = int(model.num_codes());
  const Matrix train_codes = upload<Matrix>("mpmrom::project::train_codes", model.codes, num_train, r);
  Cube g_subset("mpmrom::project::g_subset", num_train, subset.size(), 3);
  nn::evaluate(space, mlp, nn::PointsView<T, MemorySpace>(upload<Matrix>("X", X_subset, subset.size(), 3)),
               nn::CodesView<T, MemorySpace>(train_codes), g_subset);
  const auto g_train = download(g_subset);
  std::vector<double> codes(std::size_t(frames) * r);
  for (int f = 0; f < frames; ++f) {
    double best = INFINITY;
    for (int c = 0; c < num_train; ++c) {
      double misfit = 0;
      for (std::size_t i = 0; i < subset.size(); ++i)
        for (int d = 0; d < 3; ++d) {
          const double e = g_train[(c * subset.size() + i) * 3 + d] - run.x[(std::size_t(f) * P + subset[i]) * 3 + d];
          misfit += e * e;
        }
      if (misfit < best) {
        best = misfit;
        std::copy(model.codes.begin() + c * r, model.codes.begin() + (c + 1) * r, codes.begin() + f * r);
      }
    }
  }

  // Levenberg-Marquardt, every frame at once: (J^T J + mu diag(J^T J)) delta = -J^T (g - x).
  Cube g("mpmrom::project::g", frames, P, 3), velocity;
  Quad F("mpmrom::project::F", frames, P, 3, 3), J("mpmrom::project::J", frames, P, 3, r);
  Matrix device_codes("mpmrom::project::codes", frames, r);
  auto host_codes = Kokkos::create_mirror_view(device_codes);
  const auto set_codes = [&](const std::vector<double>& values) {
    for (std::size_t i = 0; i < values.size(); ++i) host_codes.data()[i] = T(values[i]);
    Kokkos::deep_copy(device_codes, host_codes);
  };
  const auto cost_of = [&](const std::vector<double>& positions, int f) {
    double cost = 0;
    for (int i = 0; i < P * 3; ++i) {
      const double e = positions[std::size_t(f) * P * 3 + i] - run.x[std::size_t(f) * P * 3 + i];
      cost += e * e;
    }
    return cost;
  };
  std::vector<double> mu(frames, 1e-3), cost(frames);
  std::vector<bool> converged(frames, false);
  for (int iteration = 0; iteration < 100; ++iteration) {
    set_codes(codes);
    nn::evaluate_with_jacobians(space, mlp, nn::PointsView<T, MemorySpace>(X),
                                nn::CodesView<T, MemorySpace>(device_codes), nn::CodesView<T, MemorySpace>(), g, F, J,
                                velocity);
    const auto g_host = download(g);
    const auto J_host = download(J);
    std::vector<double> trial = codes;
    for (int f = 0; f < frames; ++f) {
      cost[f] = cost_of(g_host, f);
      if (converged[f]) continue;
      std::vector<double> JtJ(r * r, 0.0), Jtr(r, 0.0);
      for (int p = 0; p < P; ++p)
        for (int k = 0; k < 3; ++k) {
          const std::size_t row = (std::size_t(f) * P + p) * 3 + k;
          const double res = g_host[row] - run.x[row];
          const double* Jrow = &J_host[row * r];
          for (int a = 0; a < r; ++a) {
            Jtr[a] += Jrow[a] * res;
            for (int b = 0; b < r; ++b) JtJ[a * r + b] += Jrow[a] * Jrow[b];
          }
        }
      std::vector<double> A = JtJ, delta(r);
      double trace = 0;
      for (int a = 0; a < r; ++a) trace += JtJ[a * r + a];
      for (int a = 0; a < r; ++a) A[a * r + a] += mu[f] * JtJ[a * r + a] + 1e-14 * trace;
      for (int a = 0; a < r; ++a) delta[a] = -Jtr[a];
      if (!dense::SerialCholesky(A.data(), r, r)) {
        mu[f] *= 10;
        continue;
      }
      dense::SerialCholeskySolve(A.data(), r, r, delta.data());
      for (int a = 0; a < r; ++a) trial[f * r + a] += delta[a];
    }
    // Accept each frame's step if it lowers that frame's misfit, else damp more.
    set_codes(trial);
    nn::evaluate(space, mlp, nn::PointsView<T, MemorySpace>(X), nn::CodesView<T, MemorySpace>(device_codes), g);
    const auto g_trial = download(g);
    bool all_done = true;
    for (int f = 0; f < frames; ++f) {
      if (converged[f]) continue;
      const double new_cost = cost_of(g_trial, f);
      if (new_cost < cost[f]) {
        // converged once a step gains less than a part in 1e6 of the misfit (rounding level in float)
        if (cost[f] - new_cost <= 1e-6 * cost[f]) converged[f] = true;
        std::copy(trial.begin() + f * r, trial.begin() + (f + 1) * r, codes.begin() + f * r);
        mu[f] = std::max(mu[f] / 3, 1e-9);
      } else {
        mu[f] *= 5;
        if (mu[f] > 1e8) converged[f] = true;  // no descent left at any damping: a local minimum
      }
      all_done = all_done && converged[f];
    }
    if (all_done) break;
  }
  return codes;
}

ErrorAccumulator reconstruction_errors(const Model& model, const Snapshot& run, const std::vector<double>& codes,
                                       const std::vector<int>& points) {
  const int r = model.latent_dim;
  const int P = int(run.num_points), frames = int(run.num_frames);
  if (codes.size() != std::size_t(frames) * r) throw std::invalid_argument("one code per frame is needed");
  RateStencil stencil;
  stencil.add_run(run.time, 0);
  const auto rates = stencil.rates(codes, r);
  const nn::MlpLayout layout = model.layout();
  const Vector weights = upload<Vector>("mpmrom::errors::weights", model.weights, layout.num_params);
  const auto mlp = device_mlp(model, weights);
  Cube g("mpmrom::errors::g", frames, P, 3), velocity("mpmrom::errors::v", frames, P, 3);
  Quad F("mpmrom::errors::F", frames, P, 3, 3), J("mpmrom::errors::J", frames, P, 3, r);
  nn::evaluate_with_jacobians(ExecutionSpace(), mlp,
                              nn::PointsView<T, MemorySpace>(upload<Matrix>("X", run.X, P, 3)),
                              nn::CodesView<T, MemorySpace>(upload<Matrix>("codes", codes, frames, r)),
                              nn::CodesView<T, MemorySpace>(upload<Matrix>("rates", rates, frames, r)), g, F, J,
                              velocity);
  const auto g_host = download(g), F_host = download(F), v_host = download(velocity);
  double centroid[3] = {0, 0, 0};
  for (int p = 0; p < P; ++p)
    for (int d = 0; d < 3; ++d) centroid[d] += run.X[3 * p + d] / P;
  std::vector<int> all;
  if (points.empty()) {
    all.resize(P);
    std::iota(all.begin(), all.end(), 0);
  }
  ErrorAccumulator errors;
  for (int f = 0; f < frames; ++f)
    for (const int p : points.empty() ? all : points) {
      const std::size_t i = std::size_t(f) * P + p;
      errors.add(centroid, &run.X[3 * p], &run.x[3 * i], &g_host[3 * i], &run.v[3 * i], &v_host[3 * i], &run.F[9 * i],
                 &F_host[9 * i]);
    }
  return errors;
}

// The network benchmark lives here, not in bench.cpp: nvcc's wrappers for the KOKKOS_LAMBDAs of src/manifold/nn/ break
// (a call through a null pointer) when two translation units instantiate the same kernel template, so every
// instantiation of the training kernels stays in this one file.
NnBenchmark bench_nn(const NnBenchmarkSettings& settings) {
  using ExecutionSpace = Kokkos::DefaultExecutionSpace;
  using MemorySpace = ExecutionSpace::memory_space;
  using T = real_t;
  const ExecutionSpace space;
  const nn::MlpLayout layout = nn::MlpLayout::make(settings.latent_dim, settings.width, settings.depth);
  const int r = settings.latent_dim, P = settings.points, B = settings.codes;
  const int S = std::max(B, settings.batch_snapshots);  // snapshots available to the minibatches
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uniform(-1, 1);
  auto random_view = [&](auto view) {
    auto host = Kokkos::create_mirror_view(view);
    for (std::size_t i = 0; i < host.size(); ++i) host.data()[i] = T(uniform(rng) * 0.3);
    Kokkos::deep_copy(view, host);
    return view;
  };
  Kokkos::View<T*, MemorySpace> params =
      random_view(Kokkos::View<T*, MemorySpace>("mpmrom::bench::params", layout.num_params + S * r));
  nn::Mlp<T, MemorySpace> mlp;
  mlp.layout = layout;
  mlp.params = params;
  using Matrix = Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>;
  using Cube = Kokkos::View<T***, Kokkos::LayoutRight, MemorySpace>;
  using Quad = Kokkos::View<T****, Kokkos::LayoutRight, MemorySpace>;
  const Matrix X = random_view(Matrix("mpmrom::bench::X", P, 3));
  const Matrix codes = random_view(Matrix("mpmrom::bench::codes", B, r));
  const Matrix rates = random_view(Matrix("mpmrom::bench::rates", B, r));
  Cube g("mpmrom::bench::g", B, P, 3), v("mpmrom::bench::v", B, P, 3);
  Quad F("mpmrom::bench::F", B, P, 3, 3), J("mpmrom::bench::J", B, P, 3, r);

  NnBenchmark result;
  const double macs = double(layout.forward_macs());
  const double last_hidden = layout.dims[layout.num_layers - 1];
  result.evaluations = long(B) * P;
  result.flops_per_evaluation = 2 * (macs + 3 * (macs - 3 * last_hidden));
  auto evaluate = [&]() {
    nn::evaluate_with_jacobians(space, mlp, nn::PointsView<T, MemorySpace>(X), nn::CodesView<T, MemorySpace>(codes),
                                nn::CodesView<T, MemorySpace>(rates), g, F, J, v);
  };
  evaluate();
  space.fence();
  auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < settings.repeats; ++i) evaluate();
  space.fence();
  result.evaluation_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / settings.repeats;

  // Training: minibatches of batch_snapshots x points_per_snapshot samples over S random snapshots.
  const nn::Channels channels = nn::Channels::make(settings.lambda_gradient, settings.lambda_velocity);
  const int per_snapshot = std::min(settings.points_per_snapshot, P);
  const int num_samples = settings.batch_snapshots * per_snapshot;
  nn::BatchSamples<T, MemorySpace> batch;
  batch.samples_per_snapshot = per_snapshot;
  batch.X = X;
  batch.x = random_view(Cube("mpmrom::bench::x", S, P, 3));
  batch.F = random_view(Cube("mpmrom::bench::F", S, P, 9));
  batch.v = random_view(Cube("mpmrom::bench::v", S, P, 3));
  Kokkos::View<int*, MemorySpace> sample_points("mpmrom::bench::points", num_samples),
      batch_snapshots("mpmrom::bench::snapshots", settings.batch_snapshots), from("from", S), to("to", S);
  {
    auto points_host = Kokkos::create_mirror_view(sample_points);
    for (int i = 0; i < num_samples; ++i) points_host(i) = int(rng() % P);
    Kokkos::deep_copy(sample_points, points_host);
    auto snapshots_host = Kokkos::create_mirror_view(batch_snapshots);
    for (int i = 0; i < settings.batch_snapshots; ++i) snapshots_host(i) = int(rng() % S);
    Kokkos::deep_copy(batch_snapshots, snapshots_host);
    auto from_host = Kokkos::create_mirror_view(from);
    auto to_host = Kokkos::create_mirror_view(to);
    for (int s = 0; s < S; ++s) {
      from_host(s) = std::max(s - 1, 0);
      to_host(s) = std::min(s + 1, S - 1);
    }
    Kokkos::deep_copy(from, from_host);
    Kokkos::deep_copy(to, to_host);
  }
  batch.point = sample_points;
  batch.snapshot = batch_snapshots;
  batch.row = batch_snapshots;
  nn::CodeTable<T, MemorySpace> table;
  table.code_offset = layout.num_params;
  table.latent_dim = r;
  table.rate_from = from;
  table.rate_to = to;
  Kokkos::View<T*, MemorySpace> inv_dt("mpmrom::bench::inv_dt", S), grad("mpmrom::bench::grad", params.extent(0)),
      m("mpmrom::bench::m", params.extent(0)), second("mpmrom::bench::v", params.extent(0));
  Kokkos::deep_copy(inv_dt, T(10));
  table.rate_inv_dt = inv_dt;
  nn::LossWeights<T> weights;
  weights.lambda_gradient = settings.lambda_gradient ? 1 : 0;
  weights.lambda_velocity = settings.lambda_velocity ? 1 : 0;
  nn::TrainingBuffers<T, MemorySpace> buffers(space, layout, channels, num_samples, settings.batch_snapshots);
  long step = 0;
  auto train_step = [&]() {
    nn::minibatch_loss(space, mlp, table, channels, weights, batch, buffers, grad);
    nn::adam_step(space, params, Kokkos::View<const T*, MemorySpace>(grad), m, second, 0, int(params.extent(0)),
                  1e-6, ++step);
  };
  train_step();
  space.fence();
  start = std::chrono::steady_clock::now();
  for (int i = 0; i < settings.repeats; ++i) train_step();
  space.fence();
  result.training_step_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / settings.repeats;
  result.training_samples = num_samples;
  result.flops_per_training_sample = 2 * 3 * channels.count * macs;
  return result;
}

}  // namespace mpmrom
