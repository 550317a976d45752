#include "bench.hpp"

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <chrono>
#include <random>

#include "kernels/nn/adam.hpp"
#include "kernels/nn/mlp.hpp"
#include "kernels/nn/mlp_train.hpp"

#include <chrono>

#include "runtime.hpp"

namespace mpmrom {

FomBenchmark bench_fom(const Scene& scene, P2GStrategy strategy, long steps, long warmup) {
  FomSolver solver(scene, strategy);
  const double dt = solver.stable_time_step();
  for (long s = 0; s < warmup; ++s) solver.step(dt);
  Kokkos::fence();
  const auto start = std::chrono::steady_clock::now();
  for (long s = 0; s < steps; ++s) solver.step(dt);
  Kokkos::fence();
  FomBenchmark result;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.particles = solver.num_particles();
  result.grid_nodes = solver.grid().num_nodes();
  result.steps = steps;
  result.dt = dt;
  return result;
}

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

nlohmann::json benchmark_record(const std::string& benchmark, const std::string& scene) {
  const RuntimeInfo info = runtime_info();
  return {{"benchmark", benchmark},
          {"scene", scene},
          {"device", info.device},
          {"backend", info.backend},
          {"threads", info.threads},
          {"precision", info.precision},
          {"kokkos_version", info.kokkos_version},
          {"mpmrom_version", info.version},
          {"git_commit", info.git_commit}};
}

}  // namespace mpmrom
