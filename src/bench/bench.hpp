// Timings of the solvers, as benchmark records (SPEC.md: device, backend, threads, precision, versions, figures with
// units in their names).
#pragma once

#include "core/benchmark_record.hpp"
#include "fom/fom.hpp"
#include "manifold/bench_nn.hpp"
#include "mpmrom/model.hpp"
#include "mpmrom/rom.hpp"

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

struct RomBenchmark {
  std::size_t particles = 0;     // the scene's material points
  std::size_t model_points = 0;  // those the model was trained on
  int samples = 0, rollouts = 0, frames = 0;
  long steps = 0;            // time steps of the timed output intervals (each advances every rollout)
  double seconds = 0;        // their wall-clock time (the batch waits for the device at each output)
  double setup_seconds = 0;  // the model onto the scene's points, the samples and their sets, the batch
  int stopped_rollouts = 0;  // by the end of the timed intervals (a stopped rollout costs nothing more)
  RomSettings settings;      // as run: the random selection and the masses as weights
};

// The reduced model's step on the scene, its cost and not its accuracy: the model decoded at the scene's own material
// points (model_at_scene_points; on its own scene, its own points), settings.samples random samples (settings.seed)
// weighted by their masses, no fitted weights and no step bound (both need the scene's training runs), `rollouts`
// copies of the scene's parameter values; `warmup` untimed output intervals, then `frames` timed ones.
RomBenchmark bench_rom(const Model& model, const Scene& scene, RomSettings settings, int rollouts, int frames,
                       int warmup);

}  // namespace mpmrom
