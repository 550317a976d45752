// Particle-to-grid transfer (APIC or PIC) with the internal (stress) and external forces folded into the grid momentum:
//   m_i  = sum_p w_ip m_p
//   mv_i = sum_p w_ip (m_p v_p + m_p C_p (x_i - x_p)) + dt (w_ip f_p - V_p^0 tau_p grad w_ip)
// with tau = P F^T the Kirchhoff stress. Three interchangeable accumulation strategies: atomics on the grid; scatter:
// per-thread copies of the grid on CPUs (grid_copies.hpp), atomics on GPUs; or tiles: a team sums its particles into a
// box of nodes in scratch (shared) memory, then adds the box to the grid, so that particles stored near each other (the
// FOM can store them brick by brick) cost a few global atomics per node instead of one per particle and node.
// Parallelism: one thread per particle, or a block of consecutive particles on CPUs (atomic, scatter); a team per
// block of consecutive particles (tiles).
#pragma once

#include <stdexcept>
#include <type_traits>

#include "core/light_launch.hpp"
#include "mpm/bspline.hpp"
#include "mpm/constitutive.hpp"
#include "mpm/constitutive_lanes.hpp"
#include "mpm/grid.hpp"
#include "mpm/grid_copies.hpp"
#include "mpm/particles.hpp"

namespace mpmrom {

constexpr int kMaxExternalForces = 4;

// Current total external forces (N), three components each; particle p carries force_share(p, k) of force k.
struct ExternalForces {
  Kokkos::Array<real_t, 3 * kMaxExternalForces> force;
  int count = 0;
};

enum class P2GStrategy { Atomic, Scatter, Tiled };

// The per-particle work of P2G, shared by both accumulation strategies.
template <class MemorySpace>
struct P2GParticle {
  ParticleViews<MemorySpace> particles;
  GridGeometry<real_t> grid;
  ElasticMaterial<real_t> material;
  ExternalForces external;
  real_t dt;
  bool apic;
  Kokkos::View<int, MemorySpace> outside;  // counts particles whose stencil left `reach`
  // (particles): V_p Psi(F_p) of the state P2G reads, written when not empty (the FOM's energy-checking steps)
  Kokkos::View<double*, MemorySpace> elastic_energy;
  // The grid nodes the step prepares (NodeBox::whole, or the box the last G2P's positions reach): a particle whose
  // stencil leaves it adds nothing and counts as outside; the FOM then stops, as for a point that left the grid.
  NodeBox reach;

  template <class Add>
  KOKKOS_INLINE_FUNCTION void operator()(int p, const Add& add) const {
    const Vec3<real_t> x = load_vec3(particles.x, p);
    const auto s = quadratic_stencil(x, grid.origin, grid.inv_dx);
    const bool with_energy = elastic_energy.extent(0) > 0;
    if (!reach.holds_stencil(s.base)) {
      Kokkos::atomic_add(&outside(), 1);
      if (with_energy) elastic_energy(p) = 0;  // the step fails: it left the grid
      return;
    }
    const real_t m = particles.mass(p);
    const Vec3<real_t> momentum = m * load_vec3(particles.v, p);
    const Mat3<real_t> affine = apic ? m * load_mat3(particles.C, p) : Mat3<real_t>::zero();
    const Mat3<real_t> F = load_mat3(particles.F, p);
    real_t psi = 0;
    const Mat3<real_t> tau = kirchhoff_stress(material, F, with_energy ? &psi : nullptr);
    const Mat3<real_t> stress = (-dt * particles.volume(p)) * tau;
    if (with_energy) elastic_energy(p) = double(particles.volume(p)) * double(psi);
    Vec3<real_t> impulse = Vec3<real_t>::zero();  // dt * external force on this particle
    for (int k = 0; k < external.count; ++k) {
      const real_t share = dt * particles.force_share(p, k);
      for (int d = 0; d < 3; ++d) impulse[d] += share * external.force[3 * k + d];
    }
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        for (int c = 0; c < 3; ++c) {
          const real_t w = s.weight(a, b, c);
          const Vec3<real_t> offset = s.node_offset(a, b, c, x, grid.origin, grid.dx);
          const Vec3<real_t> node_momentum = w * (momentum + affine * offset + impulse) + stress * s.gradient(a, b, c);
          const int ijk[3] = {s.base[0] + a, s.base[1] + b, s.base[2] + c};
          add(grid.index(ijk[0], ijk[1], ijk[2]), ijk, w * m, node_momentum);
        }
  }
};

// P2G's work for the particles [first, first + count) of a block (count <= particle_lanes, CPUs): the stencils, the
// stresses (kirchhoff_stress_lanes) and the 27 nodes' shares computed side by side for the block (the lane loops
// vectorised; each particle's shares P2GParticle's, factored by axis), then the shares added particle by particle,
// so that every node still receives its particles in increasing order.
template <class MemorySpace, class Add>
KOKKOS_INLINE_FUNCTION void p2g_block(const P2GParticle<MemorySpace>& kernel, int first, int count, const Add& add) {
  constexpr int L = particle_lanes;
  const ParticleViews<MemorySpace>& particles = kernel.particles;
  const GridGeometry<real_t>& grid = kernel.grid;
  const bool with_energy = kernel.elastic_energy.extent(0) > 0;
  real_t x[3][L], w[3][3][L], dw[3][3][L];
  int base[3][L];
  bool inside[L];
  for (int l = 0; l < L; ++l)  // lanes past the end repeat the block's first particle and add nothing
    for (int d = 0; d < 3; ++d) x[d][l] = particles.x(l < count ? first + l : first, d);
  for (int d = 0; d < 3; ++d) quadratic_weights_lanes<L>(x[d], grid.origin[d], grid.inv_dx, base[d], w[d], dw[d]);
  // Per particle: its momentum, m C, dt times its external force, and -dt V tau (the stresses across the lanes).
  real_t mass[L], momentum[3][L], affine[3][3][L], impulse[3][L], stress[3][3][L], F[3][3][L], psi[L];
  for (int l = 0; l < L; ++l) {
    const int p = l < count ? first + l : first;
    const int b[3] = {base[0][l], base[1][l], base[2][l]};
    inside[l] = l < count && kernel.reach.holds_stencil(b);
    if (l < count && !inside[l]) Kokkos::atomic_add(&kernel.outside(), 1);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) F[i][j][l] = particles.F(p, i, j);
  }
  kirchhoff_stress_lanes(kernel.material, F, stress, with_energy ? &psi : nullptr);
  for (int l = 0; l < L; ++l) {
    const int p = l < count ? first + l : first;
    if (with_energy && l < count)  // a point that left the grid fails the step: no energy
      kernel.elastic_energy(p) = inside[l] ? double(particles.volume(p)) * double(psi[l]) : 0.0;
    if (!inside[l]) {  // reads the grid's first stencil and adds nothing
      for (int d = 0; d < 3; ++d) base[d][l] = 0;
      mass[l] = 0;
      for (int i = 0; i < 3; ++i) {
        momentum[i][l] = impulse[i][l] = 0;
        for (int j = 0; j < 3; ++j) affine[i][j][l] = stress[i][j][l] = 0;
      }
      continue;
    }
    const real_t m = particles.mass(p);
    mass[l] = m;
    for (int i = 0; i < 3; ++i) momentum[i][l] = m * particles.v(p, i);
    const real_t scale = -kernel.dt * particles.volume(p);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        affine[i][j][l] = kernel.apic ? m * particles.C(p, i, j) : real_t(0);
        stress[i][j][l] = scale * stress[i][j][l];
      }
    Vec3<real_t> dt_force = Vec3<real_t>::zero();
    for (int k = 0; k < kernel.external.count; ++k) {
      const real_t share = kernel.dt * particles.force_share(p, k);
      for (int d = 0; d < 3; ++d) dt_force[d] += share * kernel.external.force[3 * k + d];
    }
    for (int i = 0; i < 3; ++i) impulse[i][l] = dt_force[i];
  }
  // Every node's share for every lane: w m and w (m v + m C (x_i - x_p) + dt f) - dt V tau grad w. The weight, its
  // gradient and the offset x_i - x_p factor by axis (w = w0 w1 w2, offset component d from axis d's node alone), so
  // with P = m v + dt f, A = m C and S = -dt V tau the share of node (a, b, c) is w2 X + w0 w1 Z(c), where
  //   X = w0 w1 (P + A_0 o0 + A_1 o1) + S_0 dw0 w1 + S_1 w0 dw1 (per a, b) and Z(c) = w2 A_2 o2 + S_2 dw2 (per c):
  // a third of the arithmetic of the node-by-node sum (A_j, S_j: column j).
  const real_t dx = grid.dx;
  real_t offset[3][3][L], z[3][3][L], mass_w2[3][L];  // offset[axis][node along it][lane], z[c][component][lane]
  MPMROM_SIMD for (int l = 0; l < L; ++l) {
    for (int d = 0; d < 3; ++d)
      for (int a = 0; a < 3; ++a) offset[d][a][l] = grid.origin[d] + real_t(base[d][l] + a) * dx - x[d][l];
    for (int c = 0; c < 3; ++c) {
      mass_w2[c][l] = mass[l] * w[2][c][l];
      for (int i = 0; i < 3; ++i)
        z[c][i][l] = w[2][c][l] * (affine[i][2][l] * offset[2][c][l]) + stress[i][2][l] * dw[2][c][l];
    }
  }
  real_t node_mass[27][L], node_momentum[27][3][L];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      MPMROM_SIMD for (int l = 0; l < L; ++l) {
        const real_t w01 = w[0][a][l] * w[1][b][l];
        real_t X[3];
        for (int i = 0; i < 3; ++i)
          X[i] = w01 * (momentum[i][l] + impulse[i][l] + affine[i][0][l] * offset[0][a][l] +
                        affine[i][1][l] * offset[1][b][l]) +
                 stress[i][0][l] * (dw[0][a][l] * w[1][b][l]) + stress[i][1][l] * (w[0][a][l] * dw[1][b][l]);
        for (int c = 0; c < 3; ++c) {
          const int k = (a * 3 + b) * 3 + c;
          node_mass[k][l] = w01 * mass_w2[c][l];
          for (int i = 0; i < 3; ++i) node_momentum[k][i][l] = w[2][c][l] * X[i] + w01 * z[c][i][l];
        }
      }
    }
  if constexpr (Add::adds_rows) {  // a row of the stencil is three contiguous nodes: twelve values at once
    for (int l = 0; l < count; ++l) {
      if (!inside[l]) continue;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          real_t row[12];
          for (int c = 0; c < 3; ++c) {
            const int k = (a * 3 + b) * 3 + c;
            row[4 * c] = node_mass[k][l];
            for (int i = 0; i < 3; ++i) row[4 * c + 1 + i] = node_momentum[k][i][l];
          }
          add.add_row(grid.index(base[0][l] + a, base[1][l] + b, base[2][l]), row);
        }
    }
  } else {
    for (int l = 0; l < count; ++l) {
      if (!inside[l]) continue;
      for (int k = 0; k < 27; ++k) {
        const int ijk[3] = {base[0][l] + k / 9, base[1][l] + (k / 3) % 3, base[2][l] + k % 3};
        const Vec3<real_t> share{{node_momentum[k][0][l], node_momentum[k][1][l], node_momentum[k][2][l]}};
        add(grid.index(ijk[0], ijk[1], ijk[2]), ijk, node_mass[k][l], share);
      }
    }
  }
}

// Accumulators: add(node, (i, j, k) of node, mass, momentum) sums one particle's share into one node; those with
// adds_rows also take a stencil row at once (GridCopyAdd).
template <class MemorySpace>
struct AtomicGridAdd {
  GridNodeView<MemorySpace> nodes;
  static constexpr bool adds_rows = false;
  KOKKOS_INLINE_FUNCTION void operator()(int node, const int*, real_t mass, const Vec3<real_t>& momentum) const {
#if defined(__CUDA_ARCH__) && (__CUDA_ARCH__ >= 900)
    // Compute capability 9.0 adds a float4 in one atomic: a quarter of the L2 atomic operations that bound P2G.
    // The node's four entries are contiguous and 16-byte aligned (GridNodeView is LayoutRight).
    if constexpr (std::is_same_v<real_t, float>) {
      atomicAdd(reinterpret_cast<float4*>(&nodes(node, 0)), make_float4(mass, momentum[0], momentum[1], momentum[2]));
    } else
#endif
    {
      Kokkos::atomic_add(&nodes(node, 0), mass);
      for (int d = 0; d < 3; ++d) Kokkos::atomic_add(&nodes(node, d + 1), momentum[d]);
    }
  }
};

// A box of nodes [lo, lo + extent) in team scratch memory, one component after the other (mass, then momentum x,
// y, z), so that the threads of a team that add to neighbouring nodes touch neighbouring banks.
template <class ScratchView>
struct TileGridAdd {
  ScratchView tile;
  static constexpr bool adds_rows = false;
  int lo[3];
  int extent[3];
  int volume;
  KOKKOS_INLINE_FUNCTION int local(const int ijk[3]) const {
    return ((ijk[0] - lo[0]) * extent[1] + (ijk[1] - lo[1])) * extent[2] + (ijk[2] - lo[2]);
  }
  // The grid node of tile entry l: the inverse of local().
  KOKKOS_INLINE_FUNCTION int grid_node(int l, const GridGeometry<real_t>& grid) const {
    const int k = l % extent[2], j = (l / extent[2]) % extent[1], i = l / (extent[1] * extent[2]);
    return grid.index(lo[0] + i, lo[1] + j, lo[2] + k);
  }
  KOKKOS_INLINE_FUNCTION void operator()(int, const int ijk[3], real_t mass, const Vec3<real_t>& momentum) const {
    const int l = local(ijk);
    Kokkos::atomic_add(&tile(l), mass);
    for (int d = 0; d < 3; ++d) Kokkos::atomic_add(&tile((d + 1) * volume + l), momentum[d]);
  }
};

// Launches `kernel` over the particles, one a thread or in blocks (p2g_block), with the accumulator that
// make_add(), called in each work item, returns.
template <class ExecutionSpace, class MemorySpace, class MakeAdd>
void p2g_launch(const char* name, const ExecutionSpace& space, const P2GParticle<MemorySpace>& kernel,
                ParticleLaunch launch, const MakeAdd& make_add) {
  const int n = static_cast<int>(kernel.particles.size());
  if constexpr (Kokkos::SpaceAccessibility<ExecutionSpace, Kokkos::HostSpace>::accessible) {
    if (launch == ParticleLaunch::Blocks) {
      constexpr int L = particle_lanes;
      Kokkos::parallel_for(
          name, Kokkos::RangePolicy<ExecutionSpace>(space, 0, (n + L - 1) / L), KOKKOS_LAMBDA(const int block) {
            const int first = block * L;
            p2g_block(kernel, first, n - first < L ? n - first : L, make_add());
          });
      return;
    }
  }
  Kokkos::parallel_for(
      name, Kokkos::RangePolicy<ExecutionSpace, LightWeight>(space, 0, n),
      KOKKOS_LAMBDA(const int p) { kernel(p, make_add()); });
}

// P2G with atomic adds into `nodes`, which the caller has zeroed.
template <class ExecutionSpace, class MemorySpace>
void p2g_atomic(const ExecutionSpace& space, const P2GParticle<MemorySpace>& kernel,
                const GridNodeView<MemorySpace>& nodes,
                ParticleLaunch launch = default_particle_launch<ExecutionSpace>()) {
  const AtomicGridAdd<MemorySpace> add{nodes};
  p2g_launch(
      "mpmrom::fom::p2g_atomic", space, kernel, launch, KOKKOS_LAMBDA() { return add; });
}

// P2G through the threads' grid copies (host backends; copies of kernel.grid's nodes), whose sums over kernel.reach
// (which holds every stencil that adds) become those nodes of `nodes`; on devices, atomics into `nodes`, which the
// caller has zeroed over kernel.reach.
template <class ExecutionSpace, class MemorySpace>
void p2g_scatter(const ExecutionSpace& space, const P2GParticle<MemorySpace>& kernel,
                 const GridCopies<ExecutionSpace>& copies, const GridNodeView<MemorySpace>& nodes,
                 ParticleLaunch launch = default_particle_launch<ExecutionSpace>()) {
  if constexpr (Kokkos::SpaceAccessibility<ExecutionSpace, Kokkos::HostSpace>::accessible) {
    if (!copies.allocated() || copies.num_nodes() != kernel.grid.num_nodes())
      throw std::logic_error("p2g_scatter: the grid copies were not made for this grid");
    p2g_launch("mpmrom::fom::p2g_scatter", space, kernel, launch, copies.make_add());
    copies.sum_into(space, nodes, kernel.reach, kernel.grid);
  } else {
    (void)copies;
    p2g_atomic(space, kernel, nodes, launch);
  }
}

// Tiled P2G's shape: threads per team, consecutive particles per team, and the largest box (in nodes) that a team
// sums in scratch memory; a team whose particles' stencils span a larger box adds them with global atomics.
struct P2GTiling {
  int team_size;
  int particles_per_team;
  int max_tile_nodes;
};

// One thread a team on host backends (the tile is then a per-thread cache of the grid); on GPUs 128 threads over 256
// particles, which the FOM's brick order (4^3 cells of about 8 particles) keeps inside one brick's 6^3 nodes. The
// tile limit keeps the scratch at 16 kB in float (32 kB in double), well inside a GPU block's shared memory.
template <class ExecutionSpace>
P2GTiling default_p2g_tiling() {
  using Memory = typename ExecutionSpace::memory_space;
  constexpr bool host = Kokkos::SpaceAccessibility<Kokkos::HostSpace, Memory>::accessible;
  return host ? P2GTiling{1, 256, 1024} : P2GTiling{128, 256, 1024};
}

// P2G through team scratch tiles into `nodes`, which the caller has zeroed.
template <class ExecutionSpace, class MemorySpace>
void p2g_tiled(const ExecutionSpace& space, const P2GParticle<MemorySpace>& kernel,
               const GridNodeView<MemorySpace>& nodes, const P2GTiling& tiling) {
  using Policy = Kokkos::TeamPolicy<ExecutionSpace>;
  using Member = typename Policy::member_type;
  using ScratchSpace = typename ExecutionSpace::scratch_memory_space;
  using TileView = Kokkos::View<real_t*, ScratchSpace, Kokkos::MemoryTraits<Kokkos::Unmanaged>>;
  using BoxView = Kokkos::View<int[6], ScratchSpace, Kokkos::MemoryTraits<Kokkos::Unmanaged>>;
  const int n = static_cast<int>(kernel.particles.size());
  const int per_team = tiling.particles_per_team, max_nodes = tiling.max_tile_nodes;
  if (n == 0) return;
  const int teams = (n + per_team - 1) / per_team;
  const std::size_t scratch = BoxView::shmem_size() + TileView::shmem_size(4 * std::size_t(max_nodes));
  const AtomicGridAdd<MemorySpace> global_add{nodes};
  const GridGeometry<real_t> grid = kernel.grid;
  Kokkos::parallel_for(
      "mpmrom::fom::p2g_tiled", Policy(space, teams, tiling.team_size).set_scratch_size(0, Kokkos::PerTeam(scratch)),
      KOKKOS_LAMBDA(const Member& team) {
        const int first = team.league_rank() * per_team;
        const int last = first + per_team < n ? first + per_team : n;
        // The box of every stencil of the team's particles: lowest base node and highest base node per axis.
        BoxView box(team.team_scratch(0));
        Kokkos::single(Kokkos::PerTeam(team), [&]() {
          for (int d = 0; d < 3; ++d) {
            box(d) = grid.dims[d];
            box(3 + d) = -1;
          }
        });
        team.team_barrier();
        Kokkos::parallel_for(Kokkos::TeamThreadRange(team, first, last), [&](const int p) {
          const auto s = quadratic_stencil(load_vec3(kernel.particles.x, p), grid.origin, grid.inv_dx);
          if (!kernel.reach.holds_stencil(s.base)) return;
          for (int d = 0; d < 3; ++d) {
            Kokkos::atomic_fetch_min(&box(d), s.base[d]);
            Kokkos::atomic_fetch_max(&box(3 + d), s.base[d]);
          }
        });
        team.team_barrier();
        TileGridAdd<TileView> add;
        long volume = 1;
        for (int d = 0; d < 3; ++d) {
          add.lo[d] = box(d);
          add.extent[d] = box(3 + d) < box(d) ? 0 : box(3 + d) - box(d) + 3;
          volume *= add.extent[d];
        }
        if (volume == 0 || volume > max_nodes) {  // no particle inside (each counts itself), or too spread out
          Kokkos::parallel_for(Kokkos::TeamThreadRange(team, first, last), [&](const int p) { kernel(p, global_add); });
          return;
        }
        add.volume = static_cast<int>(volume);
        add.tile = TileView(team.team_scratch(0), 4 * std::size_t(max_nodes));
        Kokkos::parallel_for(Kokkos::TeamThreadRange(team, 4 * add.volume), [&](const int i) { add.tile(i) = 0; });
        team.team_barrier();
        Kokkos::parallel_for(Kokkos::TeamThreadRange(team, first, last), [&](const int p) { kernel(p, add); });
        team.team_barrier();
        Kokkos::parallel_for(Kokkos::TeamThreadRange(team, add.volume), [&](const int l) {
          const real_t mass = add.tile(l);
          const Vec3<real_t> momentum{
              {add.tile(add.volume + l), add.tile(2 * add.volume + l), add.tile(3 * add.volume + l)}};
          if (mass == real_t(0) && momentum[0] == real_t(0) && momentum[1] == real_t(0) && momentum[2] == real_t(0))
            return;
          global_add(add.grid_node(l, grid), nullptr, mass, momentum);
        });
      });
}

}  // namespace mpmrom
