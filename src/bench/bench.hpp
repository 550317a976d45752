// Timings of the solvers, as benchmark records (SPEC.md: device, backend, threads, precision, versions, figures with
// units in their names).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "fom/fom.hpp"

namespace mpmrom {

struct FomBenchmark {
  std::size_t particles = 0;
  int grid_nodes = 0;
  long steps = 0;
  double seconds = 0;           // wall-clock time of the timed steps, synchronised
  double dt = 0;                // the (CFL) step used
  // The memory traffic a step cannot avoid, counting each field once per pass that needs it: P2G reads x, v, C, F,
  // mass, volume and the force shares; G2P reads x and F and writes v, C, F and x; the force power reads v and the
  // shares; the grid is zeroed, then read and written by the grid update (G2P's and P2G's node traffic is assumed
  // to hit in cache). Bytes per step.
  double particle_bytes = 0, grid_bytes = 0;
};

// Runs `warmup` untimed steps, then `steps` timed steps of the scene at its CFL time step.
FomBenchmark bench_fom(const Scene& scene, P2GStrategy strategy, const P2GTiling& tiling, ParticleOrder order,
                       long steps, long warmup);

struct NnBenchmarkSettings {
  int latent_dim = 5, width = 48, depth = 5;
  int points = 1368, codes = 256;                        // forward-with-Jacobians batch: codes x points pairs
  int batch_snapshots = 8, points_per_snapshot = 128;    // training minibatch
  bool lambda_gradient = true, lambda_velocity = true;   // which tangent channels training carries
  int repeats = 20;
};

struct NnBenchmark {
  long evaluations = 0;            // (point, code) pairs per forward-with-Jacobians call
  double evaluation_seconds = 0;   // per call
  double flops_per_evaluation = 0; // g, dg/dX and dg/dxhat: forward pass plus three reverse sweeps
  long training_samples = 0;       // per minibatch step
  double training_step_seconds = 0;
  double flops_per_training_sample = 0;  // forward with tangents, weight gradient, input adjoint
};

// Times the network kernels on random weights and data: the fused forward with Jacobians (used by rollouts) and one
// training step (minibatch loss (7), its gradient and Adam).
NnBenchmark bench_nn(const NnBenchmarkSettings& settings);

// A benchmark record with the runtime's identity (device, backend, threads, precision, versions) filled in.
nlohmann::json benchmark_record(const std::string& benchmark, const std::string& scene);

}  // namespace mpmrom
