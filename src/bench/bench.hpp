// Timings of the solvers, as benchmark records (SPEC.md: device, backend, threads, precision, versions, figures with
// units in their names).
#pragma once

#include "core/benchmark_record.hpp"
#include "fom/fom.hpp"
#include "manifold/bench_nn.hpp"

namespace mpmrom {

struct FomBenchmark {
  std::size_t particles = 0;
  int grid_nodes = 0;
  long steps = 0;
  double seconds = 0;  // wall-clock time of the timed steps, synchronised
  double dt = 0;       // the (CFL) step used
  // The memory traffic a step cannot avoid, counting each field once per pass that needs it: P2G reads x, v, C, F,
  // mass, volume and the force shares; G2P reads x and F and writes v, C, F and x; the force power reads v and the
  // shares; the grid is zeroed, then read and written by the grid update (G2P's and P2G's node traffic is assumed
  // to hit in cache). Bytes per step.
  double particle_bytes = 0, grid_bytes = 0;
};

// Runs `warmup` untimed steps, then `steps` timed steps of the scene at its CFL time step.
FomBenchmark bench_fom(const Scene& scene, P2GStrategy strategy, const P2GTiling& tiling, ParticleOrder order,
                       long steps, long warmup);

}  // namespace mpmrom
