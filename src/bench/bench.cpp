#include "bench/bench.hpp"

#include "core/timing.hpp"

namespace mpmrom {

FomBenchmark bench_fom(const Scene& scene, P2GStrategy strategy, const P2GTiling& tiling, ParticleOrder order,
                       long steps, long warmup) {
  FomSolver solver(scene, strategy, tiling, order);
  const double dt = solver.stable_time_step();
  for (long s = 0; s < warmup; ++s) solver.step(dt);
  Kokkos::fence();
  const auto start = SteadyClock::now();
  for (long s = 0; s < steps; ++s) solver.step(dt);
  Kokkos::fence();
  FomBenchmark result;
  result.seconds = seconds_since(start);
  result.particles = solver.num_particles();
  result.grid_nodes = solver.grid().num_nodes();
  result.steps = steps;
  result.dt = dt;
  const double forces = double(scene.forces.size());
  const double particle_reals = (26 + forces) + (12 + 24) + (forces > 0 ? 3 + forces : 0);
  result.particle_bytes = sizeof(real_t) * particle_reals * double(result.particles);
  result.grid_bytes = sizeof(real_t) * (4 + 4 + 4) * double(result.grid_nodes);
  return result;
}

}  // namespace mpmrom
