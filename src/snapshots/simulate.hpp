// Full-order runs to snapshot files: one scene (simulate) or the scene's whole parameter design (sweep).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "fom/fom.hpp"
#include "core/parallel.hpp"

namespace mpmrom {

struct SimulationProgress {
  int frame;       // output frames written so far
  int num_frames;  // frames in the run
  double time;     // simulated time, s
  long steps;      // steps taken
  std::size_t num_particles;
  double seconds;       // wall-clock time so far
  double step_seconds;  // of which advancing the solver (no output): the cost of the simulation itself
};
using SimulationCallback = std::function<void(const SimulationProgress&)>;

// The one loop that drives the full-order model through the scene's output times t_k = end_time * k / num_outputs,
// k = 0 .. num_outputs (t_0 = 0: the initial state). After each, on_frame gets the frame and the wall seconds the
// advance took (fenced: the simulation alone, no output). A SimulationFailure propagates out of the step it happened
// in, after the frames before it were handed over. simulate writes them to a file, the stability map keeps them.
using FrameCallback = std::function<void(const ParticleFrame& frame, double step_seconds)>;
void advance_through_outputs(FomSolver& solver, const Scene& scene, const FrameCallback& on_frame);

// Runs `scene` from t = 0 to its end time, writing every output time to the snapshot file at `out_path`
// (atomically: nothing appears there unless the run completes).
void simulate(const Scene& scene, const std::string& out_path, P2GStrategy strategy,
              const SimulationCallback& progress = {});

struct SweepRun {
  std::vector<double> values;  // one per design parameter
  bool test = false;           // in the test split
  std::string file;            // relative to the sweep directory
};

// The runs of a scene's design, with their split and file names (runs/run_000.h5, ...).
std::vector<SweepRun> sweep_runs(const Scene& scene);

// Simulates every run of the design of the scene at `scene_path` into `out_dir`/runs/, then writes
// `out_dir`/design.csv (header: the parameter names, split, file). `on_run` is told before each run starts, and
// whether the run was reused. resume: a run whose snapshot is already complete and holds this run's scene is kept
// (each snapshot appears only once its run has finished, so a killed sweep loses at most the run it was in); one of
// another scene is an error, an unreadable one is simulated again. Under MPI (comm of several ranks) the runs are
// dealt round-robin to the ranks, and rank 0 writes design.csv once every run is written.
using SweepRunCallback = std::function<void(std::size_t run, std::size_t num_runs, const SweepRun&, bool reused)>;
void sweep(const std::string& scene_path, const std::string& out_dir, P2GStrategy strategy,
           const SweepRunCallback& on_run = {}, const SimulationCallback& progress = {}, bool resume = false,
           const parallel::Communicator& comm = parallel::Communicator::self());

}  // namespace mpmrom
