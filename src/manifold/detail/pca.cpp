#include "manifold/detail/pca.hpp"

#include "core/math/symmetric_eigen.hpp"

#include <algorithm>
#include <cmath>

namespace mpmrom {
namespace {

// Orthonormalises the m columns of Q (rows x m, row-major) in place by modified Gram-Schmidt; a column that
// vanishes against the previous ones is left at zero.
void orthonormalise(std::vector<double>& Q, std::size_t rows, int m) {
  for (int k = 0; k < m; ++k) {
    for (int j = 0; j < k; ++j) {
      double dot = 0;
      for (std::size_t i = 0; i < rows; ++i) dot += Q[i * m + j] * Q[i * m + k];
      for (std::size_t i = 0; i < rows; ++i) Q[i * m + k] -= dot * Q[i * m + j];
    }
    double norm = 0;
    for (std::size_t i = 0; i < rows; ++i) norm += Q[i * m + k] * Q[i * m + k];
    norm = std::sqrt(norm);
    for (std::size_t i = 0; i < rows; ++i) Q[i * m + k] = norm > 0 ? Q[i * m + k] / norm : 0.0;
  }
}

}  // namespace

std::vector<double> principal_coordinates(const std::vector<double>& data, std::size_t rows, std::size_t cols, int r) {
  // Centred data and its rows x rows Gram matrix: its eigenvectors scaled by sqrt(eigenvalue) are the principal
  // coordinates, and it is small when there are fewer snapshots than point coordinates.
  std::vector<double> mean(cols, 0.0), centred(data);
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t j = 0; j < cols; ++j) mean[j] += data[i * cols + j] / double(rows);
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t j = 0; j < cols; ++j) centred[i * cols + j] -= mean[j];
  std::vector<double> gram(rows * rows);
  for (std::size_t a = 0; a < rows; ++a)
    for (std::size_t b = 0; b <= a; ++b) {
      double dot = 0;
      for (std::size_t j = 0; j < cols; ++j) dot += centred[a * cols + j] * centred[b * cols + j];
      gram[a * rows + b] = gram[b * rows + a] = dot;
    }

  // Subspace iteration for the leading m = min(r + 2, rows) eigenvectors (two guard vectors speed it up), then
  // Rayleigh-Ritz on the m x m projection.
  const int m = int(std::min<std::size_t>(std::size_t(r) + 2, rows));
  std::vector<double> Q(rows * m), Z(rows * m);
  for (std::size_t i = 0; i < rows; ++i)
    for (int k = 0; k < m; ++k) Q[i * m + k] = std::cos(double(i * (k + 1)) + 0.5 * k);  // deterministic start
  orthonormalise(Q, rows, m);
  std::vector<double> B(std::size_t(m) * m), V;
  double previous = -1;
  for (int iteration = 0; iteration < 1000; ++iteration) {
    std::fill(Z.begin(), Z.end(), 0.0);
    for (std::size_t i = 0; i < rows; ++i)
      for (std::size_t l = 0; l < rows; ++l) {
        const double g = gram[i * rows + l];
        for (int k = 0; k < m; ++k) Z[i * m + k] += g * Q[l * m + k];
      }
    double trace = 0;  // sum of Rayleigh quotients: converged when it stops growing
    for (int k = 0; k < m; ++k)
      for (std::size_t i = 0; i < rows; ++i) trace += Q[i * m + k] * Z[i * m + k];
    Q.swap(Z);
    orthonormalise(Q, rows, m);
    if (std::abs(trace - previous) <= 1e-13 * std::abs(trace)) break;
    previous = trace;
  }
  std::fill(Z.begin(), Z.end(), 0.0);
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t l = 0; l < rows; ++l)
      for (int k = 0; k < m; ++k) Z[i * m + k] += gram[i * rows + l] * Q[l * m + k];
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) {
      double dot = 0;
      for (std::size_t i = 0; i < rows; ++i) dot += Q[i * m + a] * Z[i * m + b];
      B[a * m + b] = dot;
    }
  dense::symmetric_jacobi(B, V, m);
  std::vector<int> order(m);
  for (int k = 0; k < m; ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return B[a * m + a] > B[b * m + b]; });

  std::vector<double> coordinates(rows * std::size_t(r), 0.0);
  const double top = std::max(B[order[0] * m + order[0]], 0.0);
  if (top <= 0) return coordinates;
  const double first_spread = std::sqrt(top / double(rows));
  for (int k = 0; k < r && k < m; ++k) {
    const int e = order[k];
    const double lambda = B[e * m + e];
    if (!(lambda > 1e-12 * top)) break;
    std::vector<double> u(rows, 0.0);
    for (std::size_t i = 0; i < rows; ++i)
      for (int j = 0; j < m; ++j) u[i] += Q[i * m + j] * V[j * m + e];
    std::size_t largest = 0;
    for (std::size_t i = 1; i < rows; ++i)
      if (std::abs(u[i]) > std::abs(u[largest])) largest = i;
    const double sign = u[largest] < 0 ? -1.0 : 1.0;
    for (std::size_t i = 0; i < rows; ++i) coordinates[i * r + k] = sign * u[i] * std::sqrt(lambda) / first_spread;
  }
  return coordinates;
}

}  // namespace mpmrom
