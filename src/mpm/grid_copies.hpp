// P2G's accumulation on host backends without atomics: each thread sums its particles into its own copy of the grid's
// node array, then one pass over the nodes the particles reach (a NodeBox) writes each node's sum of the copies into
// the grid, copy after copy in thread order, and zeroes the copies there for the next step. For a given thread count
// the sums are bitwise reproducible (docs/reliability.md). A particle adds its stencil row by row: the three nodes of
// a row are twelve contiguous values in a copy, one vectorised add.
// Parallelism contract: a work item adds through the copy of the thread that runs it (UniqueToken); the copies cost
// threads x grid memory. Host execution spaces: on devices p2g_scatter adds with atomics and allocates no copies.
#pragma once

#include <Kokkos_Core.hpp>  // UniqueToken (its own header is private in Kokkos 4)

#include "core/math/simd.hpp"
#include "mpm/node_box.hpp"

namespace mpmrom {

// Adds into one thread's copy: the per-node form of P2GParticle's accumulators, and a stencil row at once.
struct GridCopyAdd {
  real_t* copy;  // (nodes, 4) row-major: mass, momentum x, y, z
  static constexpr bool adds_rows = true;

  KOKKOS_INLINE_FUNCTION void operator()(int node, const int*, real_t mass, const Vec3<real_t>& momentum) const {
    real_t* entry = copy + 4 * long(node);
    entry[0] += mass;
    for (int d = 0; d < 3; ++d) entry[d + 1] += momentum[d];
  }
  // The nodes first_node, first_node + 1, first_node + 2 receive values[0..3], [4..7], [8..11].
  KOKKOS_INLINE_FUNCTION void add_row(int first_node, const real_t (&values)[12]) const {
    real_t* entry = copy + 4 * long(first_node);
    MPMROM_SIMD for (int q = 0; q < 12; ++q) entry[q] += values[q];
  }
};

template <class ExecutionSpace>
class GridCopies {
 public:
  using Token = Kokkos::Experimental::UniqueToken<ExecutionSpace, Kokkos::Experimental::UniqueTokenScope::Global>;
  using CopiesView =
      Kokkos::View<real_t** [4], Kokkos::LayoutRight, typename ExecutionSpace::memory_space>;  // (threads, nodes, 4)

  GridCopies() = default;
  // Zeroed copies of a grid of num_nodes nodes, one for each thread of a host execution space (none on devices).
  explicit GridCopies(int num_nodes) {
    if constexpr (Kokkos::SpaceAccessibility<ExecutionSpace, Kokkos::HostSpace>::accessible)
      copies_ = CopiesView("mpmrom::fom::grid_copies", Token().size(), std::size_t(num_nodes));
  }

  bool allocated() const { return copies_.is_allocated(); }
  int num_nodes() const { return static_cast<int>(copies_.extent(1)); }

  // A work item's accumulator (call it in the work item: it picks the running thread's copy).
  struct MakeAdd {
    CopiesView copies;
    Token token;
    KOKKOS_INLINE_FUNCTION GridCopyAdd operator()() const {
      const int id = token.acquire();  // the thread's own id on host backends: nothing to release before reuse
      token.release(id);
      return GridCopyAdd{&copies(id, 0, 0)};
    }
  };
  MakeAdd make_add() const { return {copies_, Token()}; }

  // nodes = the sum of the copies over `box` (every particle's stencil lies inside it), then zeroes the copies
  // there.
  void sum_into(const ExecutionSpace& space, const GridNodeView<typename ExecutionSpace::memory_space>& nodes,
                const NodeBox& box, const GridGeometry<real_t>& grid) const {
    const auto copies = copies_;
    const int count = static_cast<int>(copies_.extent(0));
    for_each_box_node(
        "mpmrom::fom::sum_grid_copies", space, box, grid, KOKKOS_LAMBDA(const int node) {
          real_t sum[4] = {0, 0, 0, 0};
          for (int t = 0; t < count; ++t)
            for (int c = 0; c < 4; ++c) {
              sum[c] += copies(t, node, c);
              copies(t, node, c) = 0;
            }
          for (int c = 0; c < 4; ++c) nodes(node, c) = sum[c];
        });
  }

 private:
  CopiesView copies_;
};

}  // namespace mpmrom
