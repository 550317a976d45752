// The reference configuration as a solid (the scene's body shapes), for Algorithm 2: a quadrature point whose
// reference position falls outside every body lies outside the material and carries no mass.
// Parallelism contract: value type, read by any number of threads.
#pragma once

#include "core/math/mat3.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom::rom {

inline constexpr int max_reference_bodies = 8;

struct ReferenceDomain {
  enum Shape : int { Box = 0, Cylinder = 1, Sphere = 2 };
  int num_bodies = 0;
  Kokkos::Array<int, max_reference_bodies> shape;
  Kokkos::Array<real_t, 3 * max_reference_bodies> center;
  Kokkos::Array<real_t, 3 * max_reference_bodies> half_extents;  // box
  Kokkos::Array<real_t, max_reference_bodies> radius;            // cylinder (axis z) and sphere
  Kokkos::Array<real_t, max_reference_bodies> half_height;       // cylinder

  KOKKOS_INLINE_FUNCTION bool contains(const Vec3<real_t>& X) const {
    for (int b = 0; b < num_bodies; ++b) {
      const real_t dx = X[0] - center[3 * b], dy = X[1] - center[3 * b + 1], dz = X[2] - center[3 * b + 2];
      bool inside = false;
      switch (shape[b]) {
        case Box:
          inside = math::fabs(dx) <= half_extents[3 * b] && math::fabs(dy) <= half_extents[3 * b + 1] &&
                   math::fabs(dz) <= half_extents[3 * b + 2];
          break;
        case Cylinder: inside = dx * dx + dy * dy <= radius[b] * radius[b] && math::fabs(dz) <= half_height[b]; break;
        case Sphere: inside = dx * dx + dy * dy + dz * dz <= radius[b] * radius[b]; break;
      }
      if (inside) return true;
    }
    return false;
  }
};

}  // namespace mpmrom::rom
