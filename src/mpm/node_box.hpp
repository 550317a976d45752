// The box of grid nodes that the particles' stencils reach. The FOM's passes over the grid (zeroing it, summing the
// threads' copies, the grid update) run over this box instead of the whole grid: on the benchmark cylinders the body
// and its stencils fill about 7 % of the grid, whose walls leave room for the motion.
// Parallelism contract: value type, used by one thread at a time; for_each_box_node runs one thread per node.
#pragma once

#include <climits>

#include "core/kokkos_compat.hpp"
#include "mpm/grid.hpp"

namespace mpmrom {

// Nodes lo..hi (inclusive) along each axis; empty when hi < lo on some axis.
struct NodeBox {
  int lo[3];
  int hi[3];

  KOKKOS_INLINE_FUNCTION static NodeBox none() { return {{INT_MAX, INT_MAX, INT_MAX}, {INT_MIN, INT_MIN, INT_MIN}}; }
  static NodeBox whole(const GridGeometry<real_t>& grid) {
    return {{0, 0, 0}, {grid.dims[0] - 1, grid.dims[1] - 1, grid.dims[2] - 1}};
  }
  KOKKOS_INLINE_FUNCTION bool empty() const { return hi[0] < lo[0] || hi[1] < lo[1] || hi[2] < lo[2]; }
  KOKKOS_INLINE_FUNCTION int extent(int axis) const { return empty() ? 0 : hi[axis] - lo[axis] + 1; }
  KOKKOS_INLINE_FUNCTION long num_nodes() const { return long(extent(0)) * extent(1) * extent(2); }
  // True when the 3x3x3 stencil whose first node is `base` lies inside the box.
  KOKKOS_INLINE_FUNCTION bool holds_stencil(const int base[3]) const {
    for (int d = 0; d < 3; ++d)
      if (base[d] < lo[d] || long(base[d]) + 2 > hi[d]) return false;  // long: a far point's base may be INT_MAX
    return true;
  }
  // Adds the 3x3x3 stencil whose first node is `base`.
  KOKKOS_INLINE_FUNCTION void include_stencil(const int base[3]) {
    for (int d = 0; d < 3; ++d) {
      lo[d] = math::min(lo[d], base[d]);
      hi[d] = math::max(hi[d], base[d] + 2);  // bases come from clamped coordinates (G2P): no overflow
    }
  }
  // The grid node of entry e of the box, entries numbered with the last axis fastest (as the grid's own nodes).
  KOKKOS_INLINE_FUNCTION int node(long e, const GridGeometry<real_t>& grid) const {
    const int k = int(e % extent(2));
    const long ij = e / extent(2);
    const int j = int(ij % extent(1)), i = int(ij / extent(1));
    return grid.index(lo[0] + i, lo[1] + j, lo[2] + k);
  }
};

// `box` grown by `margin` nodes on every side, clipped to the grid; empty stays empty.
inline NodeBox padded(const NodeBox& box, int margin, const GridGeometry<real_t>& grid) {
  if (box.empty()) return box;
  NodeBox out;
  for (int d = 0; d < 3; ++d) {  // written so that a box near INT_MIN or INT_MAX (a far-away point) cannot overflow
    out.lo[d] = box.lo[d] > margin ? math::min(box.lo[d] - margin, grid.dims[d] - 1) : 0;
    out.hi[d] = box.hi[d] < grid.dims[d] - 1 - margin ? math::max(box.hi[d] + margin, 0) : grid.dims[d] - 1;
  }
  return out;
}

// Runs f(node) for every grid node of `box`, one thread a node.
template <class ExecutionSpace, class Functor>
void for_each_box_node(const char* name, const ExecutionSpace& space, const NodeBox& box,
                       const GridGeometry<real_t>& grid, const Functor& f) {
  Kokkos::parallel_for(
      name, Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(space, 0, box.num_nodes()),
      KOKKOS_LAMBDA(const long e) { f(box.node(e, grid)); });
}

// Zeroes the nodes of `box` (the other nodes are already zero between steps).
template <class ExecutionSpace, class MemorySpace>
void zero_box(const ExecutionSpace& space, const GridNodeView<MemorySpace>& nodes, const NodeBox& box,
              const GridGeometry<real_t>& grid) {
  for_each_box_node(
      "mpmrom::fom::zero_box", space, box, grid, KOKKOS_LAMBDA(const int node) {
        for (int c = 0; c < 4; ++c) nodes(node, c) = 0;
      });
}

}  // namespace mpmrom
