// Energies of the material points and the power of the external forces on them: the FOM's energy budget
// (src/fom/fom.cpp) compares kinetic + elastic energy with the initial energy plus the work put in.
//   kinetic = sum_p m_p |v_p|^2 / 2,   elastic = sum_p V_p Psi(F_p),   force power = sum_p sum_k s_pk f_k . v_p
// (s_pk: the share of external force k that point p carries). Parallelism: one thread per particle, each a reduction.
#pragma once

#include "mpm/constitutive.hpp"
#include "mpm/p2g.hpp"
#include "mpm/particles.hpp"

namespace mpmrom {

struct ParticleEnergy {
  double kinetic = 0;
  double elastic = 0;
  double total() const { return kinetic + elastic; }
};

template <class ExecutionSpace, class MemorySpace>
ParticleEnergy particle_energy(const ExecutionSpace& space, const ParticleViews<MemorySpace>& particles,
                               const ElasticMaterial<real_t>& material) {
  const Kokkos::RangePolicy<ExecutionSpace> policy(space, 0, particles.size());
  // Accumulated in double: the sums span many points and are compared against small budgets in float builds too.
  ParticleEnergy energy;
  Kokkos::parallel_reduce(
      "mpmrom::fom::kinetic_energy", policy,
      KOKKOS_LAMBDA(const int p, double& sum) {
        const Vec3<real_t> v = load_vec3(particles.v, p);
        sum += 0.5 * double(particles.mass(p)) * double(dot(v, v));
      },
      energy.kinetic);
  Kokkos::parallel_reduce(
      "mpmrom::fom::elastic_energy", policy,
      KOKKOS_LAMBDA(const int p, double& sum) {
        sum += double(particles.volume(p)) * double(energy_density(material, load_mat3(particles.F, p)));
      },
      energy.elastic);
  return energy;
}

// Kinetic + elastic energy into `energy` (a device View, so the host need not wait), the elastic part from per-point
// values V_p Psi(F_p) computed elsewhere (P2G, which has each point's polar rotation at hand, on the FOM's checking
// steps).
template <class ExecutionSpace, class MemorySpace>
void particle_energy_total(const ExecutionSpace& space, const ParticleViews<MemorySpace>& particles,
                           const Kokkos::View<double*, MemorySpace>& elastic_per_point,
                           const Kokkos::View<double, MemorySpace>& energy) {
  Kokkos::parallel_reduce(
      "mpmrom::fom::energy_total", Kokkos::RangePolicy<ExecutionSpace>(space, 0, particles.size()),
      KOKKOS_LAMBDA(const int p, double& sum) {
        const Vec3<real_t> v = load_vec3(particles.v, p);
        sum += 0.5 * double(particles.mass(p)) * double(dot(v, v)) + elastic_per_point(p);
      },
      energy);
}

// Writes the power into `power` (a device View, so the host need not wait).
template <class ExecutionSpace, class MemorySpace>
void external_force_power(const ExecutionSpace& space, const ParticleViews<MemorySpace>& particles,
                          const ExternalForces& forces, const Kokkos::View<double, MemorySpace>& power) {
  if (forces.count == 0) {
    Kokkos::deep_copy(space, power, 0.0);
    return;
  }
  Kokkos::parallel_reduce(
      "mpmrom::fom::external_force_power", Kokkos::RangePolicy<ExecutionSpace>(space, 0, particles.size()),
      KOKKOS_LAMBDA(const int p, double& sum) {
        const Vec3<real_t> v = load_vec3(particles.v, p);
        for (int k = 0; k < forces.count; ++k) {
          const real_t share = particles.force_share(p, k);
          sum += double(share *
                        (forces.force[3 * k] * v[0] + forces.force[3 * k + 1] * v[1] + forces.force[3 * k + 2] * v[2]));
        }
      },
      power);
}

}  // namespace mpmrom
