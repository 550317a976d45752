// The finite-difference stencil of the latent codes' rates in time, shared by the trainer (loss (7)'s velocity term)
// and the reconstruction errors.
#pragma once

#include <algorithm>
#include <vector>

namespace mpmrom::impl {

// The finite-difference stencil of every snapshot's code rate: central inside a run, one-sided at its ends, zero
// for a run of one frame. Snapshots are numbered run after run, frame after frame, from `base`.
struct RateStencil {
  std::vector<int> from, to;
  std::vector<double> inv_dt;

  void add_run(const std::vector<double>& times, int base) {
    const int frames = int(times.size());
    for (int f = 0; f < frames; ++f) {
      const int lo = frames == 1 ? f : std::max(f - 1, 0);
      const int hi = frames == 1 ? f : std::min(f + 1, frames - 1);
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

}  // namespace mpmrom::impl
