// The reduced model's grid work on a fixed set of nodes I (Algorithm 1 steps 3-5, Algorithm 2 steps 4-7):
// every node of I gathers the sources that can reach it (a precomputed list per node), turns momentum into velocity,
// adds gravity and applies the boundary conditions (the full-order grid update), and the sample points then read
// their velocities back from the nodes of I (G2P). Gathering instead of scattering needs no atomics, no per-rollout
// grid and sums in a fixed order: results do not depend on the thread count.
#pragma once

#include "kernels/bspline.hpp"
#include "kernels/grid.hpp"
#include "kernels/rom/sources.hpp"

namespace mpmrom::rom {

// A node's mass and momentum, summed over its sources by a vector reduction (+= joins, zero is the identity).
struct NodeSums {
  real_t mass = 0;
  real_t momentum[3] = {0, 0, 0};
  KOKKOS_INLINE_FUNCTION NodeSums& operator+=(const NodeSums& other) {
    mass += other.mass;
    for (int r = 0; r < 3; ++r) momentum[r] += other.momentum[r];
    return *this;
  }
};

// Steps 3-4 for every (rollout, node of I). Parallelism: a team thread per (rollout, node), its vector lanes taking
// the node's sources (a few hundred on a fine grid; one lane per node left small batches far from filling a GPU).
template <class ExecutionSpace>
struct GatherNodeVelocities {
  using MemorySpace = typename ExecutionSpace::memory_space;
  using member_type = typename Kokkos::TeamPolicy<ExecutionSpace>::member_type;

  GridGeometry<real_t> grid;
  Kokkos::View<const int*, MemorySpace> nodes;         // (|I|): grid node index of each node of I
  Kokkos::View<const int*, MemorySpace> offsets;       // (|I| + 1): node n gathers sources[offsets(n) .. offsets(n+1))
  Kokkos::View<const int*, MemorySpace> node_sources;  // source indices
  SourceView<MemorySpace> sources;
  Kokkos::View<const RolloutLoads*, MemorySpace> loads;
  real_t time, dt;
  BatchVectors<MemorySpace> node_velocity;  // (rollouts, |I|, 3)

  KOKKOS_INLINE_FUNCTION void operator()(const member_type& member) const {
    const int num_nodes = int(nodes.extent(0));
    const long e = long(member.league_rank()) * member.team_size() + member.team_rank();
    if (e >= long(node_velocity.extent(0)) * num_nodes) return;
    const int b = int(e / num_nodes), n = int(e % num_nodes);
    int idx[3];
    grid.indices(nodes(n), idx[0], idx[1], idx[2]);
    const Vec3<real_t> xi = grid.position(idx[0], idx[1], idx[2]);
    const int first = offsets(n);
    NodeSums sums;
    Kokkos::parallel_reduce(
        Kokkos::ThreadVectorRange(member, offsets(n + 1) - first),
        [&](const int j, NodeSums& partial) {
          const real_t* src = &sources(b, node_sources(first + j), 0);
          if (!(src[source_mass] > real_t(0))) return;
          const Vec3<real_t> x{{src[source_x], src[source_x + 1], src[source_x + 2]}};
          const auto s = quadratic_stencil(x, grid.origin, grid.inv_dx);
          const int a = idx[0] - s.base[0], c = idx[1] - s.base[1], d = idx[2] - s.base[2];
          if (a < 0 || a > 2 || c < 0 || c > 2 || d < 0 || d > 2) return;
          const real_t w = s.weight(a, c, d);
          const Vec3<real_t> grad = s.gradient(a, c, d);
          const Vec3<real_t> offset = xi - x;
          partial.mass += w * src[source_mass];
          for (int r = 0; r < 3; ++r) {
            real_t contribution = src[source_momentum + r];
            for (int q = 0; q < 3; ++q) contribution += src[source_affine + 3 * r + q] * offset[q];
            partial.momentum[r] += w * contribution;
            for (int q = 0; q < 3; ++q) partial.momentum[r] += src[source_stress + 3 * r + q] * grad[q];
          }
        },
        sums);
    Kokkos::single(Kokkos::PerThread(member), [&]() {
      Vec3<real_t> v = Vec3<real_t>::zero();
      if (sums.mass > real_t(0)) {
        const RolloutLoads& load = loads(b);
        for (int r = 0; r < 3; ++r) v[r] = sums.momentum[r] / sums.mass + dt * load.gravity[r];
        v = constrained_node_velocity(v, idx, grid, load.boundary_at(time));
      }
      for (int r = 0; r < 3; ++r) node_velocity(b, n, r) = v[r];
    });
  }
};

// Step 5 (G2P) at the sample points: v_s = sum_i w_is v_i over the 27 nodes of the sample's stencil, all of which must
// be in I (else the rollout is flagged). Reduces the largest sample speed, for the CFL limit. Parallelism: one thread
// per (rollout, sample).
template <class MemorySpace>
struct SampleVelocities {
  GridGeometry<real_t> grid;
  Kokkos::View<const int*, MemorySpace> node_slot;  // (grid nodes): position in I, or -1
  BatchVectors<MemorySpace> sample_x;
  BatchVectors<MemorySpace> node_velocity;
  BatchVectors<MemorySpace> sample_velocity;  // (rollouts, samples, 3)
  Kokkos::View<int*, MemorySpace> flags;

  KOKKOS_INLINE_FUNCTION void operator()(const long e, real_t& max_speed) const {
    const int num_samples = int(sample_x.extent(1));
    const int b = int(e / num_samples), s = int(e % num_samples);
    const Vec3<real_t> x{{sample_x(b, s, 0), sample_x(b, s, 1), sample_x(b, s, 2)}};
    const auto st = quadratic_stencil(x, grid.origin, grid.inv_dx);
    Vec3<real_t> v = Vec3<real_t>::zero();
    bool complete = grid.stencil_inside(st.base);
    for (int a = 0; a < 3 && complete; ++a)
      for (int c = 0; c < 3 && complete; ++c)
        for (int d = 0; d < 3; ++d) {
          const int slot = node_slot(grid.index(st.base[0] + a, st.base[1] + c, st.base[2] + d));
          if (slot < 0) {
            complete = false;
            break;
          }
          const real_t w = st.weight(a, c, d);
          for (int r = 0; r < 3; ++r) v[r] += w * node_velocity(b, slot, r);
        }
    if (!complete) {
      Kokkos::atomic_or(&flags(b), int(flag_left_node_set));
      v = Vec3<real_t>::zero();
    }
    for (int r = 0; r < 3; ++r) sample_velocity(b, s, r) = v[r];
    const real_t speed = norm(v);
    if (speed > max_speed) max_speed = speed;
  }
};

}  // namespace mpmrom::rom
