// Timings of the network kernels. Defined in manifold/trainer.cpp: on CUDA the KOKKOS_LAMBDAs of manifold/nn/ may be
// instantiated in one translation unit only (docs/gpu.md).
#pragma once

namespace mpmrom {

struct NnBenchmarkSettings {
  int latent_dim = 5, width = 48, depth = 5;
  int points = 1368, codes = 256;                       // forward-with-Jacobians batch: codes x points pairs
  int batch_snapshots = 8, points_per_snapshot = 128;   // training minibatch
  bool lambda_gradient = true, lambda_velocity = true;  // which tangent channels training carries
  int repeats = 20;
};

struct NnBenchmark {
  long evaluations = 0;             // (point, code) pairs per forward-with-Jacobians call
  double evaluation_seconds = 0;    // per call
  double flops_per_evaluation = 0;  // g, dg/dX and dg/dxhat: forward pass plus three reverse sweeps
  long training_samples = 0;        // per minibatch step
  double training_step_seconds = 0;
  double flops_per_training_sample = 0;  // forward with tangents, weight gradient, input adjoint
};

// Times the network kernels on random weights and data: the fused forward with Jacobians (used by rollouts) and one
// training step (minibatch loss (7), its gradient and Adam).
NnBenchmark bench_nn(const NnBenchmarkSettings& settings);

}  // namespace mpmrom
