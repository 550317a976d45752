// Micro-benchmarks of the small device kernels, on the default execution space. Run:
//   build/perf/bench_kernels --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

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
