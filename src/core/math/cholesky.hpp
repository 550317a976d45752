// Small dense symmetric positive-definite solves (r x r normal equations), written for device code.
#pragma once

#include <Kokkos_Core.hpp>

#include "core/kokkos_compat.hpp"
#include "core/math/unroll.hpp"

namespace mpmrom::dense {

// In-place Cholesky factorisation A = L L^T of the n x n row-major matrix at A (leading dimension lda): the lower
// triangle receives L, the strict upper triangle is left alone. Returns false, leaving A partly overwritten, when a
// pivot is not positive (A not positive definite in working precision). MaxN > 0 promises n <= MaxN: every loop then
// has a compile-time bound and unrolls, so that a small matrix in a local array stays in GPU registers (with runtime
// bounds it goes to local memory, a dependent load a step). Parallelism contract: one thread.
template <int MaxN = 0, class T>
KOKKOS_INLINE_FUNCTION bool SerialCholesky(T* A, const int n, const int lda) {
  constexpr bool bounded = MaxN > 0;
  const int last = bounded ? MaxN : n;
  for (int j = 0; j < last; ++j) {
    if (bounded && j >= n) break;
    T d = A[j * lda + j];
    for (int k = 0; k < j; ++k) d -= A[j * lda + k] * A[j * lda + k];
    if (!(d > T(0))) return false;
    const T ljj = math::sqrt(d);
    A[j * lda + j] = ljj;
    for (int i = j + 1; i < last; ++i) {
      if (bounded && i >= n) break;
      T s = A[i * lda + j];
      for (int k = 0; k < j; ++k) s -= A[i * lda + k] * A[j * lda + k];
      A[i * lda + j] = s / ljj;
    }
  }
  return true;
}

// Solves L L^T x = b in place (b becomes x) with the factor from SerialCholesky; MaxN as there. Parallelism
// contract: one thread.
template <int MaxN = 0, class T>
KOKKOS_INLINE_FUNCTION void SerialCholeskySolve(const T* L, const int n, const int lda, T* b) {
  constexpr bool bounded = MaxN > 0;
  const int last = bounded ? MaxN : n;
  for (int i = 0; i < last; ++i) {
    if (bounded && i >= n) break;
    T s = b[i];
    for (int k = 0; k < i; ++k) s -= L[i * lda + k] * b[k];
    b[i] = s / L[i * lda + i];
  }
  for (int i = last - 1; i >= 0; --i) {
    if (bounded && i >= n) continue;
    T s = b[i];
    for (int k = i + 1; k < last; ++k) {
      if (bounded && k >= n) break;
      s -= L[k * lda + i] * b[k];
    }
    b[i] = s / L[i * lda + i];
  }
}

// SerialCholesky and SerialCholeskySolve for a matrix whose size N is known at compile time, in local arrays: every
// loop unrolls whole, so that on GPUs the factor stays in registers (the bounded forms above leave a loop with an
// early exit, which keeps the array in local memory: on an H200 the r = 5 projection spent most of its 18 us there).
// The same operations in the same order as those. Parallelism contract: one thread.
template <int N, class T>
KOKKOS_INLINE_FUNCTION bool SerialCholeskyFixed(T (&A)[N][N]) {
  MPMROM_UNROLL
  for (int j = 0; j < N; ++j) {
    T d = A[j][j];
    MPMROM_UNROLL
    for (int k = 0; k < j; ++k) d -= A[j][k] * A[j][k];
    if (!(d > T(0))) return false;
    const T ljj = math::sqrt(d);
    A[j][j] = ljj;
    MPMROM_UNROLL
    for (int i = j + 1; i < N; ++i) {
      T s = A[i][j];
      MPMROM_UNROLL
      for (int k = 0; k < j; ++k) s -= A[i][k] * A[j][k];
      A[i][j] = s / ljj;
    }
  }
  return true;
}

template <int N, class T>
KOKKOS_INLINE_FUNCTION void SerialCholeskySolveFixed(const T (&L)[N][N], T (&b)[N]) {
  MPMROM_UNROLL
  for (int i = 0; i < N; ++i) {
    T s = b[i];
    MPMROM_UNROLL
    for (int k = 0; k < i; ++k) s -= L[i][k] * b[k];
    b[i] = s / L[i][i];
  }
  MPMROM_UNROLL
  for (int i = N - 1; i >= 0; --i) {
    T s = b[i];
    MPMROM_UNROLL
    for (int k = i + 1; k < N; ++k) s -= L[k][i] * b[k];
    b[i] = s / L[i][i];
  }
}

}  // namespace mpmrom::dense
