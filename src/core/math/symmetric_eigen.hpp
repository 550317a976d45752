// Eigen-decomposition of small dense symmetric matrices on the host (the PCA's Gram matrix, the reduced model's
// stiffness against its mass matrix).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "core/math/cholesky.hpp"

namespace mpmrom::dense {

// Eigen-decomposition of a small symmetric matrix (n x n, row-major) by cyclic Jacobi rotations: A becomes diagonal
// (the eigenvalues), V (row-major, columns = eigenvectors) accumulates the rotations.
inline void symmetric_jacobi(std::vector<double>& A, std::vector<double>& V, int n) {
  V.assign(std::size_t(n) * n, 0.0);
  for (int i = 0; i < n; ++i) V[i * n + i] = 1;
  for (int sweep = 0; sweep < 100; ++sweep) {
    double off = 0, total = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) (i == j ? total : off) += A[i * n + j] * A[i * n + j];
    if (off <= 1e-30 * (total + off)) return;
    for (int p = 0; p < n; ++p)
      for (int q = p + 1; q < n; ++q) {
        const double apq = A[p * n + q];
        if (apq == 0) continue;
        const double theta = (A[q * n + q] - A[p * n + p]) / (2 * apq);
        const double t = (theta >= 0 ? 1 : -1) / (std::abs(theta) + std::sqrt(theta * theta + 1));
        const double c = 1 / std::sqrt(t * t + 1), s = t * c;
        for (int k = 0; k < n; ++k) {  // A <- A J (columns p, q)
          const double akp = A[k * n + p], akq = A[k * n + q];
          A[k * n + p] = c * akp - s * akq;
          A[k * n + q] = s * akp + c * akq;
        }
        for (int k = 0; k < n; ++k) {  // A <- J^T A (rows p, q)
          const double apk = A[p * n + k], aqk = A[q * n + k];
          A[p * n + k] = c * apk - s * aqk;
          A[q * n + k] = s * apk + c * aqk;
        }
        for (int k = 0; k < n; ++k) {
          const double vkp = V[k * n + p], vkq = V[k * n + q];
          V[k * n + p] = c * vkp - s * vkq;
          V[k * n + q] = s * vkp + c * vkq;
        }
      }
  }
}

// The largest lambda of K v = lambda M v (r x r row-major; K's symmetric part is taken, M must be positive definite):
// the eigenvalues of L^-1 K L^-T with M = L L^T. -infinity when M is not positive definite.
inline double largest_generalised_eigenvalue(std::vector<double> K, std::vector<double> M, int r) {
  // L^-1 K L^-T with M = L L^T, by forward substitution on the columns, then on the rows
  if (!SerialCholesky(M.data(), r, r)) return -std::numeric_limits<double>::infinity();
  const auto solve_lower = [&](double* column, int stride) {  // column <- L^-1 column
    for (int i = 0; i < r; ++i) {
      double s = column[i * stride];
      for (int k = 0; k < i; ++k) s -= M[i * r + k] * column[k * stride];
      column[i * stride] = s / M[i * r + i];
    }
  };
  for (int c = 0; c < r; ++c) solve_lower(&K[c], r);              // L^-1 K
  for (int row = 0; row < r; ++row) solve_lower(&K[row * r], 1);  // (L^-1 K) L^-T
  for (int i = 0; i < r; ++i)
    for (int j = i + 1; j < r; ++j) K[i * r + j] = K[j * r + i] = 0.5 * (K[i * r + j] + K[j * r + i]);
  std::vector<double> V;
  symmetric_jacobi(K, V, r);
  double largest = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < r; ++i) largest = std::max(largest, K[i * r + i]);
  return largest;
}

}  // namespace mpmrom::dense
