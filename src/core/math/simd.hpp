// MPMROM_SIMD before a loop across a block's lanes (a compile-time count of independent values, contiguous) asks
// the host compiler to vectorise that loop itself. Without it GCC unrolls the lane loop whole and vectorises the
// loop around it instead (across a dot product's terms, with permutes), which ran the block network kernels
// (manifold/nn/mlp_block.hpp) slower than one point a thread. The build passes -fopenmp-simd, which enables the
// pragma without OpenMP's runtime; nvcc's front end takes neither, so a CUDA build's host pass has no block kernels
// (host_lane_blocks).
#pragma once

#if defined(__GNUC__) && !defined(__CUDACC__)
#define MPMROM_SIMD _Pragma("omp simd")
namespace mpmrom::math {
inline constexpr bool host_lane_blocks = true;
}
#else
#define MPMROM_SIMD
namespace mpmrom::math {
inline constexpr bool host_lane_blocks = false;
}
#endif
