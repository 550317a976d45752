// Material-point fields as structure-of-arrays Views, laid out by the memory space's default layout (row-major on
// the host, column-major on GPUs, so that consecutive threads read consecutive addresses).
#pragma once

#include "core/math/mat3.hpp"
#include "core/math/simd.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom {

template <class MemorySpace>
struct ParticleViews {
  using vector_view = Kokkos::View<real_t* [3], MemorySpace>;
  using matrix_view = Kokkos::View<real_t* [3][3], MemorySpace>;
  using scalar_view = Kokkos::View<real_t*, MemorySpace>;

  vector_view X;  // reference position
  vector_view x;  // current position
  vector_view v;  // velocity
  matrix_view F;  // deformation gradient
  matrix_view C;  // APIC affine velocity matrix (zero with PIC)
  scalar_view mass;
  scalar_view volume;                               // reference volume
  Kokkos::View<real_t**, MemorySpace> force_share;  // (n, forces): share of each external force a point carries

  ParticleViews() = default;
  ParticleViews(std::size_t n, int num_forces)
      : X("mpmrom::particles::X", n),
        x("mpmrom::particles::x", n),
        v("mpmrom::particles::v", n),
        F("mpmrom::particles::F", n),
        C("mpmrom::particles::C", n),
        mass("mpmrom::particles::mass", n),
        volume("mpmrom::particles::volume", n),
        force_share("mpmrom::particles::force_share", n, num_forces) {}

  std::size_t size() const { return x.extent(0); }
};

// How the transfers spread the particles over threads: one a thread, or blocks of particle_lanes consecutive
// particles a thread whose arithmetic runs side by side (CPUs whose compiler vectorises the lanes:
// math::host_lane_blocks).
enum class ParticleLaunch { PerParticle, Blocks };
inline constexpr int particle_lanes = 8;

template <class ExecutionSpace>
constexpr ParticleLaunch default_particle_launch() {
  return math::host_lane_blocks && Kokkos::SpaceAccessibility<ExecutionSpace, Kokkos::HostSpace>::accessible
             ? ParticleLaunch::Blocks
             : ParticleLaunch::PerParticle;
}

template <class View>
KOKKOS_INLINE_FUNCTION Vec3<real_t> load_vec3(const View& view, int p) {
  return {{view(p, 0), view(p, 1), view(p, 2)}};
}
template <class View>
KOKKOS_INLINE_FUNCTION void store_vec3(const View& view, int p, const Vec3<real_t>& a) {
  for (int d = 0; d < 3; ++d) view(p, d) = a[d];
}
template <class View>
KOKKOS_INLINE_FUNCTION Mat3<real_t> load_mat3(const View& view, int p) {
  Mat3<real_t> a;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a(i, j) = view(p, i, j);
  return a;
}
template <class View>
KOKKOS_INLINE_FUNCTION void store_mat3(const View& view, int p, const Mat3<real_t>& a) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) view(p, i, j) = a(i, j);
}

}  // namespace mpmrom
