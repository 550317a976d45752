#include "bench.hpp"

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
