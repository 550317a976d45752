// The snapshots the reduced model's offline fits use (the empirical cubature, the greedy projection selection):
// dg/dxhat and the projected fields at every point, streamed one snapshot at a time. Private to the rom stage.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "mpmrom/rom.hpp"

namespace mpmrom::impl {

// One snapshot, a row per point: dg/dxhat (rows, 3, r), the fields whose projections J^T (field) the samples must
// reproduce (each (rows, 3)) and, for the Galerkin step, each point's reduced force per unit mass (rows, r; null:
// none). The rows are every point (points null) or, on a body larger than the offline candidates, the candidates
// alone (points: their indices, all_candidates): each row then stands for the mass of its cell's points
// (row_masses), so that the rows' mass-weighted sums are a quadrature of the all-point ones.
struct PointSnapshot {
  const double* J;
  std::vector<const double*> fields;
  const double* reduced = nullptr;
  const std::vector<int>* points = nullptr;
  const std::vector<double>* row_masses = nullptr;  // null: each row is its point, of the point's own mass
  // The reduced force's all-point sum (r values) where it is another step's than the samples' (the grid step's over
  // every point, CubatureTarget::Grid; null: the rows' mass-weighted sum of reduced).
  const double* reduced_target_sum = nullptr;
  bool sensitivity = false;  // a field's response to a latent coordinate, not a sub-step's own field
  int run = 0;  // the training run (of the stream's) it was taken from: the fits hold one run out to validate
  std::size_t blocks() const { return fields.size() + (reduced != nullptr ? 1 : 0); }
  std::size_t rows(std::size_t num_points) const { return points ? points->size() : num_points; }
  std::size_t point(std::size_t row) const { return points ? std::size_t((*points)[row]) : row; }
  // The mass a row stands for in the all-point sums, given every point's own.
  double row_mass(std::size_t row, const std::vector<double>& point_masses) const {
    return row_masses ? (*row_masses)[row] : point_masses[point(row)];
  }
  // The rows of the given points; throws std::invalid_argument when one has none.
  std::vector<std::size_t> rows_of(const std::vector<int>& wanted) const;
};
using SnapshotStream = std::function<void(const std::function<void(const PointSnapshot&)>&)>;

// The snapshots `snapshots` describes: the full-order runs, the all-point reduced motion or its training states; with
// responses (the greedy projection's trial sets; the grid methods' reduced snapshots alone), each state's sub-step
// also gives its increments' response to the latent state (PointSnapshot::sensitivity).
SnapshotStream snapshot_stream(const Model& model, const CubatureSnapshots& snapshots, bool responses = false);

// The model's codes of design run `index` (its file named run_<index>.h5 by the sweep), by time.
std::vector<std::size_t> codes_of_run(const Model& model, int index);

// The design's training runs whose codes the model holds (run_<index>.h5 of its sweep; the pipeline trains without
// its validation runs), up to max_rollouts spread evenly, as rollout cases with their design indices (indices); throws
// when the model holds none.
std::vector<RolloutCase> trained_cases(const Model& model, const Scene& scene, std::size_t max_rollouts,
                                       std::vector<int>& indices);
// The inner output frames of a training run the time-step bound probes (and the training-state snapshots' default,
// --cubature-frames): each is an all-point step on a large body; 8 of the poke scenes' 33 cut the 10^5 fits' set-up
// about threefold (docs/rom.md "Sample weights").
inline constexpr int max_state_frames = 8;
// At most max_frames of the inner output frames 1 .. frames - 2, spread evenly: the offline probes' states.
std::vector<int> inner_frames(int frames, int max_frames);
// The model's training state at inner output frame `frame` of each of the design runs `indices` (the scene has
// `frames` output frames): xhat the run's code, xhatdot the central difference of its codes (training's rate), each
// (runs, r). Throws when the model holds another number of codes of a run.
void training_state(const Model& model, const std::vector<int>& indices, int frame, int frames,
                    std::vector<double>& xhat, std::vector<double>& xhatdot);

// The candidates of the offline selections: every point, or at most max_candidates spread evenly in space over a
// larger body, one a cell of a uniform grid (points, in increasing order), each standing for the mass of its cell's
// points (masses; a uniform scale of the candidates' own masses over-weighs the part-filled cells of the surface,
// where the grid step's and the Galerkin step's integrands differ most).
struct Candidates {
  std::vector<int> points;
  std::vector<double> masses;
};
Candidates all_candidates(const Model& model, std::size_t max_candidates);

}  // namespace mpmrom::impl
