// The snapshots the reduced model's offline fits use (the empirical cubature, the greedy projection selection):
// dg/dxhat and the projected fields at every point, streamed one snapshot at a time. Private to the rom stage.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "mpmrom/rom.hpp"

namespace mpmrom::impl {

// One snapshot at every point: dg/dxhat (P, 3, r), the fields whose projections J^T (field) the samples must
// reproduce (each (P, 3)) and, for the Galerkin step, each point's reduced force per unit mass (P, r; null: none).
struct PointSnapshot {
  const double* J;
  std::vector<const double*> fields;
  const double* reduced = nullptr;
  std::size_t blocks() const { return fields.size() + (reduced != nullptr ? 1 : 0); }
};
using SnapshotStream = std::function<void(const std::function<void(const PointSnapshot&)>&)>;

// The snapshots `snapshots` describes: the full-order runs, the all-point reduced motion or its training states.
SnapshotStream snapshot_stream(const Model& model, const CubatureSnapshots& snapshots);

// Every point, or 2048 spread evenly over a larger body: the candidates of the offline selections.
std::vector<int> all_candidates(const Model& model);

}  // namespace mpmrom::impl
