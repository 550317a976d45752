// Particle-to-grid transfer (APIC or PIC) with the internal (stress) and external forces folded into the grid momentum:
//   m_i  = sum_p w_ip m_p
//   mv_i = sum_p w_ip (m_p v_p + m_p C_p (x_i - x_p)) + dt (w_ip f_p - V_p^0 tau_p grad w_ip)
// with tau = P F^T the Kirchhoff stress. Two interchangeable accumulation strategies: atomics on the grid, or a
// Kokkos ScatterView (duplicated per thread on CPUs, atomic on GPUs). Parallelism: one thread per particle.
#pragma once

#include <Kokkos_ScatterView.hpp>

#include "kernels/bspline.hpp"
#include "kernels/constitutive.hpp"
#include "kernels/grid.hpp"
#include "kernels/particles.hpp"

namespace mpmrom {

constexpr int kMaxExternalForces = 4;

// Current total external forces (N), three components each; particle p carries force_share(p, k) of force k.
struct ExternalForces {
  Kokkos::Array<real_t, 3 * kMaxExternalForces> force;
  int count = 0;
};

enum class P2GStrategy { Atomic, ScatterView };

// The per-particle work of P2G, shared by both accumulation strategies.
template <class MemorySpace>
struct P2GParticle {
  ParticleViews<MemorySpace> particles;
  GridGeometry<real_t> grid;
  ElasticMaterial<real_t> material;
  ExternalForces external;
  real_t dt;
  bool apic;
  Kokkos::View<int, MemorySpace> outside;  // counts particles whose stencil left the grid

  template <class Add>
  KOKKOS_INLINE_FUNCTION void operator()(int p, const Add& add) const {
    const Vec3<real_t> x = load_vec3(particles.x, p);
    const auto s = quadratic_stencil(x, grid.origin, grid.inv_dx);
    if (!grid.stencil_inside(s.base)) {
      Kokkos::atomic_add(&outside(), 1);
      return;
    }
    const real_t m = particles.mass(p);
    const Vec3<real_t> momentum = m * load_vec3(particles.v, p);
    const Mat3<real_t> affine = apic ? m * load_mat3(particles.C, p) : Mat3<real_t>::zero();
    const Mat3<real_t> F = load_mat3(particles.F, p);
    const Mat3<real_t> stress = (-dt * particles.volume(p)) * kirchhoff_stress(material, F);
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
          const int node = grid.index(s.base[0] + a, s.base[1] + b, s.base[2] + c);
          add(node, 0, w * m);
          for (int d = 0; d < 3; ++d) add(node, d + 1, node_momentum[d]);
        }
  }
};

template <class MemorySpace>
struct AtomicGridAdd {
  GridNodeView<MemorySpace> nodes;
  KOKKOS_INLINE_FUNCTION void operator()(int node, int component, real_t value) const {
    Kokkos::atomic_add(&nodes(node, component), value);
  }
};

template <class Access>
struct ScatterGridAdd {
  const Access& access;
  KOKKOS_INLINE_FUNCTION void operator()(int node, int component, real_t value) const {
    access(node, component) += value;
  }
};

// P2G with atomic adds into `nodes`, which the caller has zeroed.
template <class ExecutionSpace, class MemorySpace>
void p2g_atomic(const ExecutionSpace& space, const P2GParticle<MemorySpace>& kernel,
                const GridNodeView<MemorySpace>& nodes) {
  const AtomicGridAdd<MemorySpace> add{nodes};
  Kokkos::parallel_for(
      "mpmrom::fom::p2g_atomic", Kokkos::RangePolicy<ExecutionSpace>(space, 0, kernel.particles.size()),
      KOKKOS_LAMBDA(const int p) { kernel(p, add); });
}

template <class ExecutionSpace, class MemorySpace>
using GridScatterView = Kokkos::Experimental::ScatterView<real_t* [4], typename GridNodeView<MemorySpace>::array_layout,
                                                          ExecutionSpace, Kokkos::Experimental::ScatterSum>;

// P2G through a ScatterView (kept by the caller across steps so its per-thread copies are allocated once), then
// contributed into `nodes`, which the caller has zeroed.
template <class ExecutionSpace, class MemorySpace>
void p2g_scatter(const ExecutionSpace& space, const P2GParticle<MemorySpace>& kernel,
                 GridScatterView<ExecutionSpace, MemorySpace>& scatter, const GridNodeView<MemorySpace>& nodes) {
  scatter.reset();
  Kokkos::parallel_for(
      "mpmrom::fom::p2g_scatter", Kokkos::RangePolicy<ExecutionSpace>(space, 0, kernel.particles.size()),
      KOKKOS_LAMBDA(const int p) {
        auto access = scatter.access();
        kernel(p, ScatterGridAdd<decltype(access)>{access});
      });
  GridNodeView<MemorySpace> destination = nodes;  // Kokkos 3.4's contribute() takes a non-const View reference
  Kokkos::Experimental::contribute(destination, scatter);
}

}  // namespace mpmrom
