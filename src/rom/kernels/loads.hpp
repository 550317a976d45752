// The loads and boundary conditions of one rollout, with their activity windows, so that a batch of rollouts with
// different parameters (force vectors, prescribed velocities) keeps them on the device for the whole run.
// Parallelism contract: value type, read by any number of threads.
#pragma once

#include "mpm/grid_update.hpp"
#include "mpm/p2g.hpp"

namespace mpmrom::rom {

struct RolloutLoads {
  // External forces: each acts on the material whose reference position lies in its box, as a force per unit mass
  // (the total force divided by the mass the full-order model finds in the box), during [start, end).
  int num_forces = 0;
  Kokkos::Array<real_t, 3 * kMaxExternalForces> force_per_mass;
  Kokkos::Array<real_t, 6 * kMaxExternalForces> force_box;  // lo xyz, hi xyz (reference configuration)
  Kokkos::Array<real_t, 2 * kMaxExternalForces> force_window;
  // Every Dirichlet region with its window; boundary.num_dirichlet counts them all, active or not.
  GridBoundary boundary;
  Kokkos::Array<real_t, 2 * kMaxDirichletRegions> dirichlet_window;
  Vec3<real_t> gravity;

  // The boundary conditions in force at time t (the active Dirichlet regions only).
  KOKKOS_INLINE_FUNCTION GridBoundary boundary_at(real_t t) const {
    GridBoundary active = boundary;
    active.num_dirichlet = 0;
    for (int r = 0; r < boundary.num_dirichlet; ++r) {
      if (!(t >= dirichlet_window[2 * r] && t < dirichlet_window[2 * r + 1])) continue;
      const int a = active.num_dirichlet++;
      for (int d = 0; d < 6; ++d) active.dirichlet_box[6 * a + d] = boundary.dirichlet_box[6 * r + d];
      for (int d = 0; d < 3; ++d) active.dirichlet_velocity[3 * a + d] = boundary.dirichlet_velocity[3 * r + d];
    }
    return active;
  }

  // External force per unit mass on material with reference position X at time t.
  KOKKOS_INLINE_FUNCTION Vec3<real_t> force_per_unit_mass(const Vec3<real_t>& X, real_t t) const {
    Vec3<real_t> f = Vec3<real_t>::zero();
    for (int k = 0; k < num_forces; ++k) {
      if (!(t >= force_window[2 * k] && t < force_window[2 * k + 1])) continue;
      bool inside = true;
      for (int d = 0; d < 3; ++d) inside = inside && X[d] >= force_box[6 * k + d] && X[d] <= force_box[6 * k + 3 + d];
      if (!inside) continue;
      for (int d = 0; d < 3; ++d) f[d] += force_per_mass[3 * k + d];
    }
    return f;
  }
};

}  // namespace mpmrom::rom
