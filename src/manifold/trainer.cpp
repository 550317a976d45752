// Training the deformation map on the device (train_model, manifold/trainer.hpp) and the network kernels' benchmark
// (bench_nn, manifold/bench_nn.hpp): every instantiation of the training kernels (manifold/nn/) is in this file.
#include "manifold/trainer.hpp"

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/timing.hpp"
#include "manifold/bench_nn.hpp"
#include "manifold/detail/training_host.hpp"
#include "manifold/detail/training_state.hpp"
#include "manifold/nn/adam.hpp"
#include "manifold/nn/mlp_batch.hpp"
#include "manifold/nn/mlp_train.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom {
namespace {

using ExecutionSpace = Kokkos::DefaultExecutionSpace;
using MemorySpace = ExecutionSpace::memory_space;
using T = real_t;
using Vector = Kokkos::View<T*, MemorySpace>;
using Matrix = Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>;
using Cube = Kokkos::View<T***, Kokkos::LayoutRight, MemorySpace>;
using Quad = Kokkos::View<T****, Kokkos::LayoutRight, MemorySpace>;
using impl::DeviceState;
using impl::GradientSum;
using impl::MinibatchStaging;
using impl::TrainingSizes;

LossReport to_report(const nn::LossTerms<double>& sum, double samples, const TrainingSettings& s) {
  LossReport r;
  r.position = sum.position / samples;
  r.gradient = sum.gradient / samples;
  r.velocity = sum.velocity / samples;
  r.affine = sum.affine / samples;
  r.total = r.position + s.lambda_gradient * r.gradient + s.lambda_velocity * r.velocity + s.lambda_affine * r.affine;
  return r;
}

void accumulate(nn::LossTerms<double>& sum, const nn::LossTerms<T>& batch, int samples) {
  sum.position += double(batch.position) * samples;
  sum.gradient += double(batch.gradient) * samples;
  sum.velocity += double(batch.velocity) * samples;
  sum.affine += double(batch.affine) * samples;
}

// What the steps of one training run work with.
struct Training {
  const TrainingSettings& settings;
  const parallel::Communicator& comm;
  const TrainingSizes& n;
  DeviceState& device;
  MinibatchStaging& staging;
};

// Loss terms of one minibatch's samples on this rank: per_snapshot points (point_ids) of each of its snapshots
// (snapshot_ids: their codes, rows: their rows in this rank's targets); with grad not empty, their gradient too.
nn::LossTerms<T> batch_loss(const Training& t, const std::vector<int>& snapshot_ids, const std::vector<int>& rows,
                            const std::vector<int>& point_ids, int per_snapshot, long total_samples,
                            const Vector& grad) {
  DeviceState& d = t.device;
  d.batch.samples_per_snapshot = per_snapshot;
  d.batch.total_samples = total_samples;
  d.batch.snapshot = t.staging.batch_snapshots.upload(snapshot_ids);
  d.batch.row = t.staging.batch_rows.upload(rows);
  d.batch.point = t.staging.batch_points.upload(point_ids);
  return nn::minibatch_loss(d.space, d.mlp, d.table, d.channels, d.weights, d.batch,
                            t.staging.buffers.get(int(snapshot_ids.size()), per_snapshot), grad);
}

// The loss on the monitored held-out points of every training snapshot, over every rank.
LossReport validation_loss(const Training& t) {
  nn::LossTerms<double> sum;
  const int count = int(t.staging.monitor_points.size());
  const int group = t.staging.validation_group;
  for (int begin = 0; begin < t.n.num_owned; begin += group) {
    const int snaps = std::min(group, t.n.num_owned - begin);
    std::vector<int> snapshot_ids(snaps), rows(snaps), point_ids;
    for (int i = 0; i < snaps; ++i) {
      rows[i] = begin + i;
      snapshot_ids[i] = t.n.first_owned + begin + i;
      point_ids.insert(point_ids.end(), t.staging.monitor_points.begin(), t.staging.monitor_points.end());
    }
    const auto terms = batch_loss(t, snapshot_ids, rows, point_ids, count, 0, Vector());
    accumulate(sum, terms, snaps * count);
  }
  impl::sum_over_ranks(t.comm, sum);
  return to_report(sum, double(t.n.S) * count, t.settings);
}

// One epoch's minibatch losses summed over every rank, its samples, and its last learning rate.
struct EpochSum {
  nn::LossTerms<double> terms;
  double samples = 0;
  double learning_rate = 0;
};

// One epoch: every training snapshot once, in a seeded random order, per_snapshot random training points each, one
// Adam step per minibatch. step: the steps taken before, then after.
EpochSum train_epoch(const Training& t, GradientSum& gradient_sum, int epoch, const std::vector<int>& training_points,
                     long& step) {
  const TrainingSettings& settings = t.settings;
  const TrainingSizes& n = t.n;
  DeviceState& d = t.device;
  std::mt19937_64 rng(impl::epoch_seed(settings.seed, std::uint64_t(epoch)));
  std::vector<int> snapshot_order(n.S);
  std::iota(snapshot_order.begin(), snapshot_order.end(), 0);
  std::shuffle(snapshot_order.begin(), snapshot_order.end(), rng);
  std::vector<int> pool = training_points;
  EpochSum sum;
  for (int k = 0; k < n.steps_per_epoch; ++k) {
    const int begin = k * settings.batch_snapshots;
    const int snaps = std::min(settings.batch_snapshots, n.S - begin);
    // Every rank draws the whole minibatch (the same random stream) and keeps the snapshots of its share.
    std::vector<int> snapshot_ids, rows, point_ids;
    point_ids.reserve(std::size_t(snaps) * n.per_snapshot);
    for (int i = 0; i < snaps; ++i) {
      const int snapshot = snapshot_order[std::size_t(begin + i)];
      const bool owned = snapshot >= n.first_owned && snapshot < n.first_owned + n.num_owned;
      if (owned) {
        snapshot_ids.push_back(snapshot);
        rows.push_back(snapshot - n.first_owned);
      }
      // a fresh partial Fisher-Yates draw of distinct points for each snapshot
      for (int j = 0; j < n.per_snapshot; ++j) {
        const std::size_t pick = j + std::size_t(rng() % (pool.size() - j));
        std::swap(pool[j], pool[pick]);
        if (owned) point_ids.push_back(pool[j]);
      }
    }
    nn::LossTerms<T> terms;
    if (!snapshot_ids.empty())
      terms = batch_loss(t, snapshot_ids, rows, point_ids, n.per_snapshot, long(snaps) * n.per_snapshot, d.grad);
    else
      Kokkos::deep_copy(d.space, d.grad, T(0));
    if (t.comm.size() > 1) gradient_sum.sum(d.space, d.grad, t.comm);
    ++step;
    const double progress = n.total_steps > 1 ? double(step - 1) / double(n.total_steps - 1) : 0.0;
    sum.learning_rate =
        settings.learning_rate * std::pow(settings.final_learning_rate / settings.learning_rate, progress);
    nn::adam_step(d.space, d.params, Kokkos::View<const T*, MemorySpace>(d.grad), d.first_moment, d.second_moment, 0,
                  n.num_total, sum.learning_rate, step);
    accumulate(sum.terms, terms, snaps * n.per_snapshot);
    sum.samples += double(snaps) * n.per_snapshot;
  }
  d.space.fence();
  impl::sum_over_ranks(t.comm, sum.terms);
  return sum;
}

// The progress after an epoch, with the validation loss (when there are held-out points) every validate_every
// epochs and after the last; throws if the loss diverged. first_epoch: this process's first, samples_done: its
// samples so far.
TrainingProgress epoch_progress(const Training& t, const EpochSum& sum, int epoch, std::int64_t first_epoch,
                                long samples_done, bool validate, SteadyClock::time_point start) {
  TrainingProgress progress;
  progress.epoch = epoch + 1;
  progress.epochs = t.settings.epochs;
  progress.train = to_report(sum.terms, sum.samples, t.settings);
  if (!std::isfinite(progress.train.total))
    throw std::runtime_error("training diverged at epoch " + std::to_string(epoch + 1) +
                             " (loss is not finite): lower --learning-rate");
  const bool last = epoch + 1 == t.settings.epochs;
  if (validate && ((epoch + 1) % t.n.validate_every == 0 || last)) {
    progress.validated = true;
    progress.validation = validation_loss(t);
  }
  progress.learning_rate = sum.learning_rate;
  progress.seconds = seconds_since(start);
  progress.samples_per_second = samples_done / std::max(progress.seconds, 1e-9);
  progress.seconds_left = progress.seconds / (epoch + 1 - first_epoch) * (t.settings.epochs - epoch - 1);
  return progress;
}

// Writes the state after `epochs` epochs and `step` steps to checkpoint_path.
void save_checkpoint(const Training& t, Model& model, OptimizerState& optimizer, long step, int epochs,
                     const std::string& checkpoint_path, const TrainingCallbacks& callbacks) {
  impl::download_state(t.device, t.n.num_weights, model, optimizer);
  OptimizerState state = optimizer;
  state.step = step;
  state.epoch = epochs;
  save_model(checkpoint_path, model, &state);
  impl::say(callbacks, "checkpoint after epoch " + std::to_string(epochs) + " in " + checkpoint_path);
}

// Random weights and data for the network benchmark: uniform in [-0.3, 0.3], from a fixed seed.
struct BenchRandom {
  std::mt19937_64 rng{7};
  std::uniform_real_distribution<double> uniform{-1, 1};

  template <class View>
  View fill(View view) {
    auto host = Kokkos::create_mirror_view(view);
    for (std::size_t i = 0; i < host.size(); ++i) host.data()[i] = T(uniform(rng) * 0.3);
    Kokkos::deep_copy(view, host);
    return view;
  }
};

// Seconds per call of run over `repeats` calls, after one call to warm up.
template <class Run>
double seconds_per_call(const ExecutionSpace& space, int repeats, const Run& run) {
  run();
  space.fence();
  const auto start = SteadyClock::now();
  for (int i = 0; i < repeats; ++i) run();
  space.fence();
  return seconds_since(start) / repeats;
}

// The forward pass with Jacobians of settings.codes random codes (and rates) at every point of X: result's evaluation
// entries.
void time_evaluation(const NnBenchmarkSettings& settings, const nn::Mlp<T, MemorySpace>& mlp, const Matrix& X,
                     BenchRandom& random, NnBenchmark& result) {
  const ExecutionSpace space;
  const nn::MlpLayout& layout = mlp.layout;
  const int r = settings.latent_dim, P = settings.points, B = settings.codes;
  const Matrix codes = random.fill(Matrix("mpmrom::bench::codes", B, r));
  const Matrix rates = random.fill(Matrix("mpmrom::bench::rates", B, r));
  Cube g("mpmrom::bench::g", B, P, 3), v("mpmrom::bench::v", B, P, 3);
  Quad F("mpmrom::bench::F", B, P, 3, 3), J("mpmrom::bench::J", B, P, 3, r);
  const double macs = double(layout.forward_macs());
  const double last_hidden = layout.dims[layout.num_layers - 1];
  result.evaluations = long(B) * P;
  result.flops_per_evaluation = 2 * (macs + 3 * (macs - 3 * last_hidden));
  auto evaluate = [&]() {
    nn::evaluate_with_jacobians(space, mlp, nn::PointsView<T, MemorySpace>(X), nn::CodesView<T, MemorySpace>(codes),
                                nn::CodesView<T, MemorySpace>(rates), g, F, J, v);
  };
  result.evaluation_seconds = seconds_per_call(space, settings.repeats, evaluate);
}

// Training steps: minibatches of batch_snapshots x points_per_snapshot samples over S random snapshots, the
// network's parameters (then S codes) in params: result's training entries.
void time_training(const NnBenchmarkSettings& settings, const nn::Mlp<T, MemorySpace>& mlp, const Vector& params,
                   const Matrix& X, int S, BenchRandom& random, NnBenchmark& result) {
  const ExecutionSpace space;
  const nn::MlpLayout& layout = mlp.layout;
  const int r = settings.latent_dim, P = settings.points;
  const nn::Channels channels = nn::Channels::make(settings.lambda_gradient, settings.lambda_velocity);
  const int per_snapshot = std::min(settings.points_per_snapshot, P);
  const int num_samples = settings.batch_snapshots * per_snapshot;
  nn::BatchSamples<T, MemorySpace> batch;
  batch.samples_per_snapshot = per_snapshot;
  batch.X = X;
  batch.x = random.fill(Cube("mpmrom::bench::x", S, P, 3));
  batch.F = random.fill(Cube("mpmrom::bench::F", S, P, 9));
  batch.v = random.fill(Cube("mpmrom::bench::v", S, P, 3));
  Kokkos::View<int*, MemorySpace> sample_points("mpmrom::bench::points", num_samples),
      batch_snapshots("mpmrom::bench::snapshots", settings.batch_snapshots), from("from", S), to("to", S);
  {
    auto points_host = Kokkos::create_mirror_view(sample_points);
    for (int i = 0; i < num_samples; ++i) points_host(i) = int(random.rng() % P);
    Kokkos::deep_copy(sample_points, points_host);
    auto snapshots_host = Kokkos::create_mirror_view(batch_snapshots);
    for (int i = 0; i < settings.batch_snapshots; ++i) snapshots_host(i) = int(random.rng() % S);
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
  Vector inv_dt("mpmrom::bench::inv_dt", S), grad("mpmrom::bench::grad", params.extent(0)),
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
    nn::adam_step(space, params, Kokkos::View<const T*, MemorySpace>(grad), m, second, 0, int(params.extent(0)), 1e-6,
                  ++step);
  };
  result.training_step_seconds = seconds_per_call(space, settings.repeats, train_step);
  result.training_samples = num_samples;
  result.flops_per_training_sample = 2 * 3 * channels.count * double(layout.forward_macs());
}

}  // namespace

Model train_model(const TrainingData& data, const TrainingSettings& settings, const std::string& checkpoint_path,
                  bool resume, const TrainingCallbacks& callbacks, const parallel::Communicator& comm) {
  settings.validate();
  if (settings.max_points > 0 && data.train.runs.front().num_points > std::size_t(settings.max_points))
    throw std::invalid_argument("max_points " + std::to_string(settings.max_points) + ": the training runs hold " +
                                std::to_string(data.train.runs.front().num_points) +
                                " points (read them with load_training_data's max_points)");
  impl::TrainingTargets targets;
  Model model = impl::start_model(data, settings, targets);
  const impl::PointSplit points = impl::split_points(settings, int(data.train.runs.front().num_points));
  const TrainingSizes n = impl::sizes_of(model, settings, points, comm);
  impl::set_scales(model, targets, points.training);
  impl::set_initial_parameters(model, settings, targets, points.training);
  OptimizerState optimizer;
  optimizer.first_moment.assign(n.num_total, 0.0);
  optimizer.second_moment.assign(n.num_total, 0.0);
  if (resume) {
    impl::resume_from(checkpoint_path, model, optimizer);
    impl::say(callbacks, "resuming from " + checkpoint_path + " after epoch " + std::to_string(optimizer.epoch));
  }

  DeviceState device = impl::upload_state(model, optimizer, targets, settings, n);
  MinibatchStaging staging(model.layout(), device.channels, settings, n.per_snapshot, points.validation);
  const Training training{settings, comm, n, device, staging};
  GradientSum gradient_sum(device.grad);
  const auto start = SteadyClock::now();
  auto last_checkpoint = start;
  long samples_done = 0;
  long step = optimizer.step;
  TrainingProgress final;
  for (int epoch = int(optimizer.epoch); epoch < settings.epochs; ++epoch) {
    const EpochSum sum = train_epoch(training, gradient_sum, epoch, points.training, step);
    samples_done += long(sum.samples);
    const TrainingProgress progress =
        epoch_progress(training, sum, epoch, optimizer.epoch, samples_done, !points.validation.empty(), start);
    if (callbacks.progress) callbacks.progress(progress);
    final = progress;

    // every rank asks (the ranks hold identical parameters; rank 0 writes)
    const bool last = epoch + 1 == settings.epochs;
    if (!checkpoint_path.empty() && !last && comm.any(seconds_since(last_checkpoint) >= settings.checkpoint_seconds)) {
      if (comm.is_root()) save_checkpoint(training, model, optimizer, step, epoch + 1, checkpoint_path, callbacks);
      last_checkpoint = SteadyClock::now();
    }
  }
  impl::download_state(device, n.num_weights, model, optimizer);
  if (!comm.is_root()) return model;  // rank 0 evaluates and writes the model
  impl::set_errors(model, data, points.validation, final, start, callbacks);
  return model;
}

// The network benchmark lives here, not in bench.cpp: nvcc's wrappers for the KOKKOS_LAMBDAs of src/manifold/nn/ break
// (a call through a null pointer) when two translation units instantiate the same kernel template, so every
// instantiation of the training kernels stays in this one file.
NnBenchmark bench_nn(const NnBenchmarkSettings& settings) {
  const nn::MlpLayout layout = nn::MlpLayout::make(settings.latent_dim, settings.width, settings.depth);
  const int r = settings.latent_dim;
  const int S = std::max(settings.codes, settings.batch_snapshots);  // snapshots available to the minibatches
  BenchRandom random;
  const Vector params = random.fill(Vector("mpmrom::bench::params", layout.num_params + S * r));
  nn::Mlp<T, MemorySpace> mlp;
  mlp.layout = layout;
  mlp.params = params;
  const Matrix X = random.fill(Matrix("mpmrom::bench::X", settings.points, 3));
  NnBenchmark result;
  time_evaluation(settings, mlp, X, random, result);
  time_training(settings, mlp, params, X, S, random, result);
  return result;
}

}  // namespace mpmrom
