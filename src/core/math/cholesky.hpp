// Small dense symmetric positive-definite solves (r x r normal equations), written for device code.
#pragma once

#include <Kokkos_Core.hpp>

#include "core/kokkos_compat.hpp"

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

}  // namespace mpmrom::dense
