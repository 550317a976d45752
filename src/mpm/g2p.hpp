// Grid-to-particle transfer and particle update:
//   v_p = sum_i w_ip v_i,  C_p = (4 / dx^2) sum_i w_ip v_i (x_i - x_p)^T (APIC; zero for PIC),
//   F_p <- (I + dt sum_i v_i grad w_ip^T) F_p,  x_p <- x_p + dt v_p.
// Writes the largest particle speed, which sets the next CFL time step, into `max_speed` (a device View, so the
// host need not wait), and counts in `problems` the particles left in a state the run cannot go on from (the
// driver reports them; counting costs nothing while none occurs).
// Parallelism: one thread per particle.
#pragma once

#include "core/light_launch.hpp"
#include "mpm/bspline.hpp"
#include "mpm/grid.hpp"
#include "mpm/particles.hpp"

namespace mpmrom {

// problems(problem_not_finite): a NaN or Inf in v, x or det F; problems(problem_inverted): det F <= 0 (inverted).
enum ParticleProblem : int { problem_not_finite = 0, problem_inverted = 1, num_particle_problems = 2 };
template <class MemorySpace>
using ParticleProblemCounts = Kokkos::View<int[num_particle_problems], MemorySpace>;

template <class ExecutionSpace, class MemorySpace>
void g2p(const ExecutionSpace& space, const ParticleViews<MemorySpace>& particles,
         const GridNodeView<MemorySpace>& nodes, const GridGeometry<real_t>& grid, real_t dt, bool apic,
         const ParticleProblemCounts<MemorySpace>& problems, const Kokkos::View<real_t, MemorySpace>& max_speed) {
  // D_p^{-1} = 4 / dx^2 for quadratic B-splines (Jiang et al. 2015).
  const real_t inverse_inertia = real_t(4) * grid.inv_dx * grid.inv_dx;
  Kokkos::parallel_reduce(
      "mpmrom::fom::g2p", Kokkos::RangePolicy<ExecutionSpace, LightWeight>(space, 0, particles.size()),
      KOKKOS_LAMBDA(const int p, real_t& speed) {
        const Vec3<real_t> x = load_vec3(particles.x, p);
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
        const Mat3<real_t> F = (Mat3<real_t>::identity() + dt * velocity_gradient) * load_mat3(particles.F, p);
        const Vec3<real_t> x_next = x + dt * v;
        const real_t J = determinant(F);
        if (!math::isfinite(v[0] + v[1] + v[2] + x_next[0] + x_next[1] + x_next[2] + J))
          Kokkos::atomic_add(&problems(problem_not_finite), 1);
        else if (!(J > real_t(0)))
          Kokkos::atomic_add(&problems(problem_inverted), 1);
        store_vec3(particles.v, p, v);
        store_mat3(particles.C, p, apic ? inverse_inertia * affine : Mat3<real_t>::zero());
        store_mat3(particles.F, p, F);
        store_vec3(particles.x, p, x_next);
        speed = math::max(speed, norm(v));
      },
      Kokkos::Max<real_t, MemorySpace>(max_speed));
}

}  // namespace mpmrom
