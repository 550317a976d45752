// The background grid: a dense box of nodes (origin + index * dx), stored as one flat node array.
// Parallelism contract: value type, used by one thread at a time.
#pragma once

#include "core/math/mat3.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom {

template <class T>
struct GridGeometry {
  Vec3<T> origin;
  T dx;
  T inv_dx;
  int dims[3];  // nodes per axis

  KOKKOS_INLINE_FUNCTION int num_nodes() const { return dims[0] * dims[1] * dims[2]; }
  KOKKOS_INLINE_FUNCTION int index(int i, int j, int k) const { return (i * dims[1] + j) * dims[2] + k; }
  KOKKOS_INLINE_FUNCTION void indices(int node, int& i, int& j, int& k) const {
    k = node % dims[2];
    j = (node / dims[2]) % dims[1];
    i = node / (dims[1] * dims[2]);
  }
  KOKKOS_INLINE_FUNCTION Vec3<T> position(int i, int j, int k) const {
    return {{origin[0] + T(i) * dx, origin[1] + T(j) * dx, origin[2] + T(k) * dx}};
  }
  // True when the 3x3x3 stencil starting at `base` lies inside the grid.
  KOKKOS_INLINE_FUNCTION bool stencil_inside(const int base[3]) const {
    for (int d = 0; d < 3; ++d)
      if (base[d] < 0 || long(base[d]) + 2 >= dims[d]) return false;  // long: a far point's base may be INT_MAX
    return true;
  }
};

// Grid node fields: column 0 the mass, columns 1-3 the momentum during P2G and the velocity after the grid update.
// A node's four entries are contiguous on every backend (LayoutRight, not CUDA's default LayoutLeft): P2G adds them
// with one 16-byte atomic where the GPU has one.
template <class MemorySpace>
using GridNodeView = Kokkos::View<real_t* [4], Kokkos::LayoutRight, MemorySpace>;

}  // namespace mpmrom
