// Grid-to-particle transfer and particle update:
//   v_p = sum_i w_ip v_i,  C_p = (4 / dx^2) sum_i w_ip v_i (x_i - x_p)^T (APIC; zero for PIC),
//   F_p <- (I + dt sum_i v_i grad w_ip^T) F_p,  x_p <- x_p + dt v_p.
// Writes the largest particle speed, which sets the next CFL time step, and the box of nodes that the particles'
// new stencils reach, which bounds the next step's grid passes, into `summary` (a device View, so the host need not
// wait), and counts in `problems` the particles left in a state the run cannot go on from (the driver reports them;
// counting costs nothing while none occurs).
// Parallelism: one thread per particle on GPUs; on CPUs a thread per block of 8 consecutive particles, their
// arithmetic vectorised across the block (the same operations per particle, in the same order).
#pragma once

#include "core/light_launch.hpp"
#include "mpm/bspline.hpp"
#include "mpm/grid.hpp"
#include "mpm/node_box.hpp"
#include "mpm/particles.hpp"

namespace mpmrom {

// problems(problem_not_finite): a NaN or Inf in v, x or det F; problems(problem_inverted): det F <= 0 (inverted).
enum ParticleProblem : int { problem_not_finite = 0, problem_inverted = 1, num_particle_problems = 2 };
template <class MemorySpace>
using ParticleProblemCounts = Kokkos::View<int[num_particle_problems], MemorySpace>;

// G2P's reduction: the fastest particle's speed and the box of the nodes its new positions' stencils reach (finite
// positions only: a non-finite one stops the run).
struct G2PSummary {
  real_t max_speed;
  NodeBox box;
};

namespace detail {

// What G2P writes for one particle from the velocities of its stencil's nodes.
template <class MemorySpace>
struct G2PUpdate {
  ParticleViews<MemorySpace> particles;
  ParticleProblemCounts<MemorySpace> problems;
  GridGeometry<real_t> grid;
  real_t dt;
  real_t inverse_inertia;  // D_p^{-1} = 4 / dx^2 for quadratic B-splines (Jiang et al. 2015)
  bool apic;

  // Stores the new state of the particles first + l, l < count with inside[l], from their stencil sums, computed
  // side by side across the L lanes (the lane loop vectorised on CPUs; L = 1 on GPUs), and adds their speeds and new
  // stencils to `summary`. Lanes past count hold copies of a real particle's values and store nothing.
  template <int L>
  KOKKOS_INLINE_FUNCTION void store_lanes(int first, int count, const bool (&inside)[L], const real_t (&x)[3][L],
                                          const real_t (&v)[3][L], const real_t (&affine)[3][3][L],
                                          const real_t (&velocity_gradient)[3][3][L], G2PSummary& summary) const {
    real_t F[3][3][L], x_next[3][L], J[L], speed[L];
    int base[3][L];
    for (int l = 0; l < L; ++l)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) F[i][j][l] = particles.F(l < count ? first + l : first, i, j);
    MPMROM_SIMD for (int l = 0; l < L; ++l) {
      real_t A[3][3], G[3][3];  // F <- (I + dt grad v) F
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) A[i][k] = (i == k ? real_t(1) : real_t(0)) + dt * velocity_gradient[i][k][l];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) G[i][j] = A[i][0] * F[0][j][l] + A[i][1] * F[1][j][l] + A[i][2] * F[2][j][l];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) F[i][j][l] = G[i][j];
      J[l] = G[0][0] * (G[1][1] * G[2][2] - G[1][2] * G[2][1]) - G[0][1] * (G[1][0] * G[2][2] - G[1][2] * G[2][0]) +
             G[0][2] * (G[1][0] * G[2][1] - G[1][1] * G[2][0]);
      speed[l] = math::sqrt(v[0][l] * v[0][l] + v[1][l] * v[1][l] + v[2][l] * v[2][l]);
      for (int d = 0; d < 3; ++d) {
        x_next[d][l] = x[d][l] + dt * v[d][l];
        // quadratic_stencil's first node; a far-away or non-finite position (which stops the run) floors safely
        const real_t s = (x_next[d][l] - grid.origin[d]) * grid.inv_dx - real_t(0.5);
        base[d][l] = static_cast<int>(math::floor(s > real_t(-1e9) && s < real_t(1e9) ? s : real_t(0)));
      }
    }
    for (int l = 0; l < count; ++l) {
      if (!inside[l]) continue;
      const int p = first + l;
      if (!math::isfinite(v[0][l] + v[1][l] + v[2][l] + x_next[0][l] + x_next[1][l] + x_next[2][l] + J[l])) {
        Kokkos::atomic_add(&problems(problem_not_finite), 1);
      } else {
        if (!(J[l] > real_t(0))) Kokkos::atomic_add(&problems(problem_inverted), 1);
        const int b[3] = {base[0][l], base[1][l], base[2][l]};
        summary.box.include_stencil(b);
      }
      for (int i = 0; i < 3; ++i) {
        particles.v(p, i) = v[i][l];
        particles.x(p, i) = x_next[i][l];
        for (int j = 0; j < 3; ++j) {
          particles.C(p, i, j) = apic ? inverse_inertia * affine[i][j][l] : real_t(0);
          particles.F(p, i, j) = F[i][j][l];
        }
      }
      summary.max_speed = math::max(summary.max_speed, speed[l]);
    }
  }
};

// A G2P kernel's reduction into G2PSummary (Kokkos calls init and join).
struct G2PReduction {
  using value_type = G2PSummary;
  KOKKOS_INLINE_FUNCTION void init(value_type& summary) const {
    summary.max_speed = 0;  // speeds are >= 0
    summary.box = NodeBox::none();
  }
  KOKKOS_INLINE_FUNCTION void join(MPMROM_REDUCTION_VOLATILE value_type& dst,
                                   const MPMROM_REDUCTION_VOLATILE value_type& src) const {
    if (src.max_speed > dst.max_speed) dst.max_speed = src.max_speed;
    for (int d = 0; d < 3; ++d) {
      if (src.box.lo[d] < dst.box.lo[d]) dst.box.lo[d] = src.box.lo[d];
      if (src.box.hi[d] > dst.box.hi[d]) dst.box.hi[d] = src.box.hi[d];
    }
  }
};

// One particle a thread.
template <class MemorySpace>
struct G2PPerParticle : G2PReduction {
  G2PUpdate<MemorySpace> update;
  GridNodeView<MemorySpace> nodes;

  KOKKOS_INLINE_FUNCTION void operator()(const int p, G2PSummary& summary) const {
    const GridGeometry<real_t>& grid = update.grid;
    const Vec3<real_t> x = load_vec3(update.particles.x, p);
    const auto s = quadratic_stencil(x, grid.origin, grid.inv_dx);
    if (!grid.stencil_inside(s.base)) return;  // P2G has counted it; the driver stops the run
    Vec3<real_t> v = Vec3<real_t>::zero();
    Mat3<real_t> affine = Mat3<real_t>::zero(), velocity_gradient = Mat3<real_t>::zero();
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        for (int c = 0; c < 3; ++c) {
          const int node = grid.index(s.base[0] + a, s.base[1] + b, s.base[2] + c);
          const Vec3<real_t> vi{{nodes(node, 1), nodes(node, 2), nodes(node, 3)}};
          const real_t w = s.weight(a, b, c);
          v += w * vi;
          affine += w * outer(vi, s.node_offset(a, b, c, x, grid.origin, grid.dx));
          velocity_gradient += outer(vi, s.gradient(a, b, c));
        }
    const bool inside[1] = {true};
    real_t x1[3][1], v1[3][1], affine1[3][3][1], gradient1[3][3][1];
    for (int i = 0; i < 3; ++i) {
      x1[i][0] = x[i];
      v1[i][0] = v[i];
      for (int j = 0; j < 3; ++j) affine1[i][j][0] = affine(i, j), gradient1[i][j][0] = velocity_gradient(i, j);
    }
    update.store_lanes(p, 1, inside, x1, v1, affine1, gradient1, summary);
  }
};

// The stencil sums of particle_lanes consecutive particles side by side: each lane's sums are G2PPerParticle's, term
// for term, and only the lane loops run vectorised; so is the new state (store_lanes), then stored particle by
// particle.
template <class MemorySpace>
struct G2PBlocks : G2PReduction {
  G2PUpdate<MemorySpace> update;
  GridNodeView<MemorySpace> nodes;

  KOKKOS_INLINE_FUNCTION void operator()(const int block, G2PSummary& summary) const {
    constexpr int L = particle_lanes;
    const GridGeometry<real_t>& grid = update.grid;
    const int n = static_cast<int>(update.particles.size());
    const int first = block * L;
    const int count = n - first < L ? n - first : L;
    real_t x[3][L], w[3][3][L], dw[3][3][L];
    int base[3][L];
    bool inside[L];
    for (int l = 0; l < L; ++l)  // lanes past the end repeat the block's first particle and store nothing
      for (int d = 0; d < 3; ++d) x[d][l] = update.particles.x(l < count ? first + l : first, d);
    for (int d = 0; d < 3; ++d) quadratic_weights_lanes<L>(x[d], grid.origin[d], grid.inv_dx, base[d], w[d], dw[d]);
    for (int l = 0; l < L; ++l) {
      const int b[3] = {base[0][l], base[1][l], base[2][l]};
      inside[l] = l < count && grid.stencil_inside(b);
      if (!inside[l])  // P2G has counted it; its lane reads the grid's first stencil and stores nothing
        for (int d = 0; d < 3; ++d) base[d][l] = 0;
    }
    real_t v[3][L] = {}, affine[3][3][L] = {}, gradient[3][3][L] = {};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        for (int c = 0; c < 3; ++c) {
          real_t vi[3][L];
          for (int l = 0; l < L; ++l) {
            const int node = grid.index(base[0][l] + a, base[1][l] + b, base[2][l] + c);
            for (int d = 0; d < 3; ++d) vi[d][l] = nodes(node, d + 1);
          }
          const real_t dx = grid.dx;
          MPMROM_SIMD for (int l = 0; l < L; ++l) {
            real_t weight, g[3], offset[3];
            stencil_node_lane(a, b, c, l, w, dw, base, x, grid.origin, dx, weight, g, offset);
            for (int i = 0; i < 3; ++i) {
              v[i][l] += weight * vi[i][l];
              for (int j = 0; j < 3; ++j) {
                affine[i][j][l] += weight * (vi[i][l] * offset[j]);
                gradient[i][j][l] += vi[i][l] * g[j];
              }
            }
          }
        }
    update.store_lanes(first, count, inside, x, v, affine, gradient, summary);
  }
};

}  // namespace detail

template <class MemorySpace>
using G2PSummaryView = Kokkos::View<G2PSummary, MemorySpace>;

template <class ExecutionSpace, class MemorySpace>
void g2p(const ExecutionSpace& space, const ParticleViews<MemorySpace>& particles,
         const GridNodeView<MemorySpace>& nodes, const GridGeometry<real_t>& grid, real_t dt, bool apic,
         const ParticleProblemCounts<MemorySpace>& problems, const G2PSummaryView<MemorySpace>& summary,
         ParticleLaunch launch = default_particle_launch<ExecutionSpace>()) {
  const detail::G2PUpdate<MemorySpace> update{particles, problems, grid, dt, real_t(4) * grid.inv_dx * grid.inv_dx,
                                              apic};
  const int n = static_cast<int>(particles.size());
  if constexpr (Kokkos::SpaceAccessibility<ExecutionSpace, Kokkos::HostSpace>::accessible) {
    if (launch == ParticleLaunch::Blocks) {
      constexpr int L = particle_lanes;
      Kokkos::parallel_reduce("mpmrom::fom::g2p_blocks", Kokkos::RangePolicy<ExecutionSpace>(space, 0, (n + L - 1) / L),
                              detail::G2PBlocks<MemorySpace>{{}, update, nodes}, summary);
      return;
    }
  }
  Kokkos::parallel_reduce("mpmrom::fom::g2p", Kokkos::RangePolicy<ExecutionSpace, LightWeight>(space, 0, n),
                          detail::G2PPerParticle<MemorySpace>{{}, update, nodes}, summary);
}

}  // namespace mpmrom
