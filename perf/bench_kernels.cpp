// Micro-benchmarks of the small device kernels, on the default execution space. Run:
//   build/perf/bench_kernels --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <vector>

#include "core/math/polar3_lanes.hpp"
#include "mpm/bspline.hpp"
#include "mpmrom/mpmrom_config.hpp"
#include "mpmrom/runtime.hpp"

namespace {

using mpmrom::real_t;
using ExecutionSpace = Kokkos::DefaultExecutionSpace;

// Quadratic B-spline stencils (weights and gradients of 27 nodes) per second, summed so nothing is optimised away.
void BM_QuadraticStencil(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  Kokkos::View<real_t* [3], ExecutionSpace::memory_space> x("x", n);
  Kokkos::parallel_for(
      "mpmrom::bench::fill", Kokkos::RangePolicy<ExecutionSpace>(0, n), KOKKOS_LAMBDA(const int p) {
        for (int d = 0; d < 3; ++d) x(p, d) = real_t(1) + real_t(((p * 7919 + d * 104729) % 1000)) * real_t(1e-3);
      });
  for (auto _ : state) {
    real_t sum = 0;
    Kokkos::parallel_reduce(
        "mpmrom::bench::quadratic_stencil", Kokkos::RangePolicy<ExecutionSpace>(0, n),
        KOKKOS_LAMBDA(const int p, real_t& acc) {
          const mpmrom::Vec3<real_t> origin{{0, 0, 0}};
          const auto s =
              mpmrom::quadratic_stencil(mpmrom::Vec3<real_t>{{x(p, 0), x(p, 1), x(p, 2)}}, origin, real_t(20));
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
              for (int c = 0; c < 3; ++c) acc += s.weight(a, b, c) + s.gradient(a, b, c)[0];
        },
        sum);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK(BM_QuadraticStencil)->Arg(1 << 20)->Unit(benchmark::kMillisecond)->UseRealTime();

// Deformation gradients as MPM's elastic bodies have them: a rotation about z times a symmetric stretch with entries
// within 1 % of the identity's, different for every p.
KOKKOS_INLINE_FUNCTION mpmrom::Mat3<real_t> elastic_deformation(int p) {
  const auto u = [p](int k) { return real_t(((p * 7919 + k * 104729) % 2001) - 1000) * real_t(1e-3); };
  const real_t c = mpmrom::math::cos(real_t(3) * u(9)), s = mpmrom::math::sin(real_t(3) * u(9));
  mpmrom::Mat3<real_t> S;
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j) S(i, j) = S(j, i) = real_t(i == j) + real_t(0.01) * u(3 * i + j);
  const mpmrom::Mat3<real_t> Q{{{c, -s, 0}, {s, c, 0}, {0, 0, 1}}};
  return Q * S;
}

// The fixed corotated stress's rotation per second, one matrix a thread: Newton's polar iteration (polar_rotation,
// range(1) = 0) against svd3's U V^T (range(1) = 1).
void BM_PolarRotation(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const bool svd = state.range(1) != 0;
  for (auto _ : state) {
    real_t sum = 0;
    Kokkos::parallel_reduce(
        "mpmrom::bench::polar_rotation", Kokkos::RangePolicy<ExecutionSpace>(0, n),
        KOKKOS_LAMBDA(const int p, real_t& acc) {
          const auto F = elastic_deformation(p);
          mpmrom::Mat3<real_t> R;
          if (svd) {
            mpmrom::Mat3<real_t> U, V;
            mpmrom::Vec3<real_t> sigma;
            mpmrom::svd3(F, U, sigma, V);
            R = mpmrom::multiply_transposed(U, V);
          } else {
            R = mpmrom::polar_rotation(F);
          }
          acc += R(0, 0) + R(1, 2);
        },
        sum);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK(BM_PolarRotation)->Args({1 << 20, 0})->Args({1 << 20, 1})->Unit(benchmark::kMillisecond)->UseRealTime();

// The same rotations 8 lanes at a time on one host thread, as the CPU's block kernels take them (polar3_lanes.hpp).
void BM_PolarRotationLanes(benchmark::State& state) {
  constexpr int L = 8;
  const int n = static_cast<int>(state.range(0));
  std::vector<real_t> F(std::size_t(n) * 9);
  for (int p = 0; p < n; ++p) {
    const auto f = elastic_deformation(p);
    for (int k = 0; k < 9; ++k) F[std::size_t(p) * 9 + k] = f(k / 3, k % 3);
  }
  for (auto _ : state) {
    real_t sum = 0;
    for (int first = 0; first + L <= n; first += L) {
      real_t block[3][3][L], R[3][3][L];
      for (int l = 0; l < L; ++l)
        for (int k = 0; k < 9; ++k) block[k / 3][k % 3][l] = F[std::size_t(first + l) * 9 + k];
      mpmrom::polar_rotation_lanes(block, R);
      for (int l = 0; l < L; ++l) sum += R[0][0][l] + R[1][2][l];
    }
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK(BM_PolarRotationLanes)->Arg(1 << 16)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  mpmrom::KokkosSession kokkos;
  const auto info = mpmrom::runtime_info();
  benchmark::AddCustomContext("backend", info.backend);
  benchmark::AddCustomContext("device", info.device);
  benchmark::AddCustomContext("threads", std::to_string(info.threads));
  benchmark::AddCustomContext("precision", info.precision);
  benchmark::AddCustomContext("kokkos_version", info.kokkos_version);
  benchmark::AddCustomContext("git_commit", info.git_commit);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
