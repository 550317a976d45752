// The reduced model's grid work on a fixed set of nodes I (Algorithm 1 steps 3-5, Algorithm 2 steps 4-7):
// every node of I gathers the sources that can reach it (a precomputed list per node), turns momentum into velocity,
// adds gravity and applies the boundary conditions (the full-order grid update), and the sample points then read
// their velocities back from the nodes of I (G2P). Gathering instead of scattering needs no atomics, no per-rollout
// grid and sums in a fixed order: results do not depend on the thread count.
#pragma once

#include "mpm/bspline.hpp"
#include "mpm/grid.hpp"
#include "rom/kernels/sources.hpp"

namespace mpmrom::rom {

// A node's mass and momentum, summed over its sources (in a vector reduction: += joins, zero is the identity).
struct NodeSums {
  real_t mass = 0;
  real_t momentum[3] = {0, 0, 0};
  KOKKOS_INLINE_FUNCTION NodeSums& operator+=(const NodeSums& other) {
    mass += other.mass;
    for (int r = 0; r < 3; ++r) momentum[r] += other.momentum[r];
    return *this;
  }
};

// Step 3 for one (node, source) pair: source k of rollout b adds its share to node i at xi (grid indices idx) if its
// stencil reaches the node.
template <class MemorySpace>
KOKKOS_INLINE_FUNCTION void add_source(const GridGeometry<real_t>& grid, const SourceView<MemorySpace>& sources, int k,
                                       int b, const int idx[3], const Vec3<real_t>& xi, NodeSums& sums) {
  const real_t mass = sources(k, source_mass, b);
  if (!(mass > real_t(0))) return;
  const Vec3<real_t> x{{sources(k, source_x, b), sources(k, source_x + 1, b), sources(k, source_x + 2, b)}};
  const auto s = quadratic_stencil(x, grid.origin, grid.inv_dx);
  const int a = idx[0] - s.base[0], c = idx[1] - s.base[1], d = idx[2] - s.base[2];
  if (a < 0 || a > 2 || c < 0 || c > 2 || d < 0 || d > 2) return;
  const real_t w = s.weight(a, c, d);
  const Vec3<real_t> grad = s.gradient(a, c, d);
  const Vec3<real_t> offset = xi - x;
  sums.mass += w * mass;
  for (int r = 0; r < 3; ++r) {
    real_t contribution = sources(k, source_momentum + r, b);
    for (int q = 0; q < 3; ++q) contribution += sources(k, source_affine + 3 * r + q, b) * offset[q];
    sums.momentum[r] += w * contribution;
    for (int q = 0; q < 3; ++q) sums.momentum[r] += sources(k, source_stress + 3 * r + q, b) * grad[q];
  }
}

// Step 4: the node's velocity from its sums, with gravity and the boundary conditions.
template <class MemorySpace>
KOKKOS_INLINE_FUNCTION void write_node_velocity(const GridGeometry<real_t>& grid, const RolloutLoads& load, real_t time,
                                                real_t dt, const int idx[3], const NodeSums& sums,
                                                const BatchVectors<MemorySpace>& node_velocity, int b, int n) {
  Vec3<real_t> v = Vec3<real_t>::zero();
  if (sums.mass > real_t(0)) {
    for (int r = 0; r < 3; ++r) v[r] = sums.momentum[r] / sums.mass + dt * load.gravity[r];
    v = constrained_node_velocity(v, idx, grid, load.boundary_at(time));
  }
  for (int r = 0; r < 3; ++r) node_velocity(b, n, r) = v[r];
}

// Steps 3-4 for every (node of I, rollout), in one of two mappings; each sums in a fixed order, but not the same
// one (list order, or lane partials joined), so their results differ by round-off:
template <class MemorySpace>
struct GatherNodeVelocities {
  GridGeometry<real_t> grid;
  Kokkos::View<const int*, MemorySpace> nodes;         // (|I|): grid node index of each node of I
  Kokkos::View<const int*, MemorySpace> offsets;       // (|I| + 1): node n gathers sources[offsets(n) .. offsets(n+1))
  Kokkos::View<const int*, MemorySpace> node_sources;  // source indices
  SourceView<MemorySpace> sources;
  Kokkos::View<const RolloutLoads*, MemorySpace> loads;
  real_t time, dt;
  BatchVectors<MemorySpace> node_velocity;  // (rollouts, |I|, 3)
  int rollout_tile;                         // item order of the one-thread mapping, below

  // One thread per (node, rollout), the node's sources in a row, items ordered by tiles of rollout_tile rollouts,
  // node by node within a tile, rollouts fastest. On GPUs (tiles of 32, make_sources) a warp reads each source's
  // numbers of its 32 rollouts in whole cache lines, and the nodes sharing a source read it while a tile's sources
  // (a few MB) are still in the L2 cache; on CPUs (tiles of 1) a thread gathers a rollout's nodes one after the other.
  // For batches that fill the device, and on CPUs.
  KOKKOS_INLINE_FUNCTION void operator()(const long e) const {
    const int num_rollouts = int(node_velocity.extent(0)), num_nodes = int(nodes.extent(0));
    const long first_rollout = e / (long(rollout_tile) * num_nodes) * rollout_tile;
    const int width = int(num_rollouts - first_rollout < rollout_tile ? num_rollouts - first_rollout : rollout_tile);
    const long offset = e - first_rollout * num_nodes;
    const int n = int(offset / width), b = int(first_rollout + offset % width);
    int idx[3];
    grid.indices(nodes(n), idx[0], idx[1], idx[2]);
    const Vec3<real_t> xi = grid.position(idx[0], idx[1], idx[2]);
    NodeSums sums;
    for (int j = offsets(n); j < offsets(n + 1); ++j) add_source(grid, sources, node_sources(j), b, idx, xi, sums);
    write_node_velocity(grid, loads(b), time, dt, idx, sums, node_velocity, b, n);
  }

  // A team thread per (node, rollout), its vector lanes taking the node's sources (a few hundred on a fine grid):
  // for small batches on GPUs, which one thread per node would leave nearly idle.
  template <class Member>
  KOKKOS_INLINE_FUNCTION void operator()(const Member& member) const {
    const int num_rollouts = int(node_velocity.extent(0));
    const long e = long(member.league_rank()) * member.team_size() + member.team_rank();
    if (e >= long(nodes.extent(0)) * num_rollouts) return;
    const int n = int(e / num_rollouts), b = int(e % num_rollouts);
    int idx[3];
    grid.indices(nodes(n), idx[0], idx[1], idx[2]);
    const Vec3<real_t> xi = grid.position(idx[0], idx[1], idx[2]);
    const int first = offsets(n);
    NodeSums sums;
    Kokkos::parallel_reduce(
        Kokkos::ThreadVectorRange(member, offsets(n + 1) - first),
        [&](const int j, NodeSums& partial) {
          add_source(grid, sources, node_sources(first + j), b, idx, xi, partial);
        },
        sums);
    Kokkos::single(Kokkos::PerThread(member),
                   [&]() { write_node_velocity(grid, loads(b), time, dt, idx, sums, node_velocity, b, n); });
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
