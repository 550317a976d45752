// MPMROM_UNROLL before a loop with a compile-time trip count unrolls it whole, so that no local array it indexes
// is indexed at run time (ptxas would move such an array to local memory, a dependent load an access; nvcc's own
// heuristics leave large or nested loops rolled). The host pass of a CUDA build runs through nvcc's front end, which
// knows neither spelling there, and GCC takes its own.
#pragma once

#if defined(__CUDA_ARCH__) || defined(__clang__)
#define MPMROM_UNROLL _Pragma("unroll")
#elif defined(__GNUC__) && !defined(__CUDACC__)
#define MPMROM_UNROLL _Pragma("GCC unroll 16")
#else
#define MPMROM_UNROLL
#endif
