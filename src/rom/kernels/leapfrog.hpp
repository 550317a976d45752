// The Galerkin step's leapfrog (RomSettings::integrator, docs/rom.md "Time step"): before its terms are taken half a
// step on, the samples' velocities at the step's start, J_s(xhat_n) xhatdot_n, the momentum the projection carries
// over the whole step (taken at the midpoint it would skip half the step's turn of the tangent space), and the first
// half-drift of the latent state. Parallelism contract of both: one thread per item, rollouts that stopped left as
// they are.
#pragma once

#include "rom/kernels/projection.hpp"

namespace mpmrom::rom {

// velocity(b, s, :) = J(b, s) xhatdot(b); one item per sample of each rollout.
template <class MemorySpace>
struct TangentVelocities {
  BatchJacobians<MemorySpace> J;  // (rollouts, samples, 3, r)
  BatchMatrix<MemorySpace> xhatdot;
  BatchVectors<MemorySpace> velocity;  // out
  Kokkos::View<const int*, MemorySpace> flags;

  KOKKOS_INLINE_FUNCTION void operator()(const long item) const {
    const int samples = int(J.extent(1)), r = int(xhatdot.extent(1));
    const int b = int(item / samples), s = int(item % samples);
    if (flags(b) & fatal_flags) return;
    for (int d = 0; d < 3; ++d) {
      real_t v = 0;
      for (int k = 0; k < r; ++k) v += J(b, s, d, k) * xhatdot(b, k);
      velocity(b, s, d) = v;
    }
  }
};

// xhat += step * xhatdot; one item per latent coordinate of each rollout.
template <class MemorySpace>
struct DriftLatent {
  BatchMatrix<MemorySpace> xhat, xhatdot;
  Kokkos::View<const int*, MemorySpace> flags;
  real_t step;

  KOKKOS_INLINE_FUNCTION void operator()(const long item) const {
    const int r = int(xhat.extent(1));
    const int b = int(item / r), q = int(item % r);
    if (!(flags(b) & fatal_flags)) xhat(b, q) += step * xhatdot(b, q);
  }
};

}  // namespace mpmrom::rom
