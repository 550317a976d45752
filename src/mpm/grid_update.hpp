// Grid update: momentum to velocity, gravity, then boundary conditions in order of precedence: domain walls, the
// ground, and prescribed-velocity (Dirichlet) regions last so that they win. Parallelism: one thread per node.
#pragma once

#include "mpm/grid.hpp"
#include "mpm/node_box.hpp"

namespace mpmrom {

constexpr int kMaxDirichletRegions = 8;

enum class Contact : int { Sticky = 0, Slip = 1, Separate = 2 };

struct GridBoundary {
  Contact walls = Contact::Separate;  // on the nodes within 2 cells of each domain face
  bool ground = false;
  real_t ground_height = 0;
  Contact ground_contact = Contact::Separate;
  int num_dirichlet = 0;  // active regions: nodes inside get the prescribed velocity
  Kokkos::Array<real_t, 6 * kMaxDirichletRegions> dirichlet_box;       // lo xyz, hi xyz
  Kokkos::Array<real_t, 3 * kMaxDirichletRegions> dirichlet_velocity;  // xyz
};

// Removes the part of v that moves into a wall whose inward normal is +/- e_axis (sign = +1 or -1).
KOKKOS_INLINE_FUNCTION void apply_contact(Vec3<real_t>& v, Contact contact, int axis, real_t sign) {
  switch (contact) {
    case Contact::Sticky: v = Vec3<real_t>::zero(); break;
    case Contact::Slip: v[axis] = 0; break;
    case Contact::Separate:
      if (v[axis] * sign < 0) v[axis] = 0;
      break;
  }
}

// The node velocity after the boundary conditions, for node (i, j, k) = idx with velocity v (gravity included).
// Shared by the full-order grid update and the reduced model's node update.
KOKKOS_INLINE_FUNCTION Vec3<real_t> constrained_node_velocity(Vec3<real_t> v, const int idx[3],
                                                              const GridGeometry<real_t>& grid,
                                                              const GridBoundary& boundary) {
  for (int d = 0; d < 3; ++d) {
    if (idx[d] < 2) apply_contact(v, boundary.walls, d, real_t(1));
    if (idx[d] > grid.dims[d] - 3) apply_contact(v, boundary.walls, d, real_t(-1));
  }
  const Vec3<real_t> x = grid.position(idx[0], idx[1], idx[2]);
  if (boundary.ground && x[2] <= boundary.ground_height) apply_contact(v, boundary.ground_contact, 2, real_t(1));
  for (int r = 0; r < boundary.num_dirichlet; ++r) {
    bool inside = true;
    for (int d = 0; d < 3; ++d)
      inside = inside && x[d] >= boundary.dirichlet_box[6 * r + d] && x[d] <= boundary.dirichlet_box[6 * r + 3 + d];
    if (inside)
      for (int d = 0; d < 3; ++d) v[d] = boundary.dirichlet_velocity[3 * r + d];
  }
  return v;
}

// Writes into `work` (a device View) the work done on the grid by gravity and the boundary conditions in this step,
// sum_i m_i (v_i - p_i / m_i).v_i over the updated velocities v_i: zero for resting walls and held nodes (the impulse
// is normal to, or multiplies, a zero velocity), the input of moving Dirichlet regions and of gravity otherwise (the
// FOM's energy budget). Summed in double: it is compared with small budgets in float builds too. Updates the nodes of
// `box`, outside which every node is empty (zero mass and momentum, which the update leaves zero).
template <class ExecutionSpace, class MemorySpace>
void grid_update(const ExecutionSpace& space, const GridNodeView<MemorySpace>& nodes, const GridGeometry<real_t>& grid,
                 const NodeBox& box, const Vec3<real_t>& gravity, const GridBoundary& boundary, real_t dt,
                 const Kokkos::View<double, MemorySpace>& work) {
  Kokkos::parallel_reduce(
      "mpmrom::fom::grid_update",
      Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(space, 0, box.num_nodes()),
      KOKKOS_LAMBDA(const long entry, double& node_work) {
        const int node = box.node(entry, grid);
        const real_t m = nodes(node, 0);
        if (m <= real_t(0)) {
          for (int d = 1; d < 4; ++d) nodes(node, d) = 0;
          return;
        }
        const real_t inv_m = real_t(1) / m;
        const Vec3<real_t> v{{nodes(node, 1) * inv_m + dt * gravity[0], nodes(node, 2) * inv_m + dt * gravity[1],
                              nodes(node, 3) * inv_m + dt * gravity[2]}};
        int idx[3];
        grid.indices(node, idx[0], idx[1], idx[2]);
        const Vec3<real_t> constrained = constrained_node_velocity(v, idx, grid, boundary);
        for (int d = 0; d < 3; ++d) {
          node_work += double((m * constrained[d] - nodes(node, d + 1)) * constrained[d]);
          nodes(node, d + 1) = constrained[d];
        }
      },
      work);
}

}  // namespace mpmrom
