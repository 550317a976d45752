// The finite-difference stencil of the latent codes' rates in time, shared by the trainer (loss (7)'s velocity term)
// and the reconstruction errors.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

#include "mpmrom/snapshot.hpp"

namespace mpmrom::impl {

// The finite-difference stencil of every snapshot's code rate: central inside a run, one-sided at its ends, zero
// for a run of one frame, and zero at the first frame of a run that starts at rest (every velocity zero there):
// the forward difference would ask the tangent space at the initial state to be blind along the motion the run then
// takes, which the reduced model, starting from xhatdot = 0 there, must follow (docs/training.md). Snapshots are
// numbered run after run, frame after frame, from `base`.
struct RateStencil {
  std::vector<int> from, to;
  std::vector<double> inv_dt;

  void add_run(const std::vector<double>& times, int base, bool starts_at_rest) {
    const int frames = int(times.size());
    for (int f = 0; f < frames; ++f) {
      const bool still = frames == 1 || (f == 0 && starts_at_rest);
      const int lo = still ? f : std::max(f - 1, 0);
      const int hi = still ? f : std::min(f + 1, frames - 1);
      from.push_back(base + lo);
      to.push_back(base + hi);
      inv_dt.push_back(hi > lo ? 1.0 / (times[hi] - times[lo]) : 0.0);
    }
  }
  std::vector<double> rates(const std::vector<double>& codes, int r) const {
    std::vector<double> out(from.size() * r);
    for (std::size_t s = 0; s < from.size(); ++s)
      for (int q = 0; q < r; ++q) out[s * r + q] = (codes[to[s] * r + q] - codes[from[s] * r + q]) * inv_dt[s];
    return out;
  }
};

// Whether every velocity of the run's first frame is zero.
inline bool starts_at_rest(const Snapshot& run) {
  const std::size_t first = 3 * run.num_points;
  return run.num_frames > 0 && run.v.size() >= first &&
         std::all_of(run.v.begin(), run.v.begin() + std::ptrdiff_t(first), [](double v) { return v == 0.0; });
}

}  // namespace mpmrom::impl
