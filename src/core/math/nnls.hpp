// Non-negative least squares on the host (Lawson and Hanson's active-set method), for the empirical cubature weights
// of the reduced model's samples: min |E w - f| subject to w >= 0, through the normal equations G = E^T E, h = E^T f
// (n unknowns, a few dozen: the passive-set solves are n x n Cholesky factorisations).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "core/math/cholesky.hpp"

namespace mpmrom::dense {

// Solves min_w w^T G w / 2 - h^T w subject to w >= 0 for the n x n symmetric positive semi-definite G (row-major).
// Returns w; an unknown enters the passive set while its gradient h - G w is above tolerance * max |h| and fewer
// than max_active unknowns are positive (0: no limit), so the active-set order doubles as a greedy selection (ECSW).
// A tiny ridge (1e-12 of G's largest diagonal entry) keeps the passive solves defined when columns coincide.
inline std::vector<double> nnls_normal(const std::vector<double>& G, const std::vector<double>& h, std::size_t n,
                                       std::size_t max_active = 0, double tolerance = 1e-10) {
  std::vector<double> w(n, 0.0), z(n, 0.0);
  std::vector<bool> passive(n, false);
  double scale = 0, diagonal = 0;
  for (std::size_t i = 0; i < n; ++i) {
    scale = std::max(scale, std::fabs(h[i]));
    diagonal = std::max(diagonal, G[i * n + i]);
  }
  if (scale == 0 || diagonal == 0) return w;
  // z = the unconstrained minimiser on the passive set (zero elsewhere).
  const auto solve_passive = [&]() {
    std::vector<std::size_t> index;
    for (std::size_t i = 0; i < n; ++i)
      if (passive[i]) index.push_back(i);
    const std::size_t m = index.size();
    std::vector<double> L(m * m), x(m);
    for (std::size_t a = 0; a < m; ++a) {
      x[a] = h[index[a]];
      for (std::size_t b = 0; b < m; ++b) L[a * m + b] = G[index[a] * n + index[b]] + (a == b ? 1e-12 * diagonal : 0);
    }
    std::fill(z.begin(), z.end(), 0.0);
    if (m == 0 || !SerialCholesky(L.data(), int(m), int(m))) return;
    SerialCholeskySolve(L.data(), int(m), int(m), x.data());
    for (std::size_t a = 0; a < m; ++a) z[index[a]] = x[a];
  };
  for (std::size_t outer = 0; outer < 3 * n; ++outer) {
    if (max_active > 0 && std::size_t(std::count(passive.begin(), passive.end(), true)) >= max_active) break;
    std::size_t best = n;
    double best_gradient = tolerance * scale;
    for (std::size_t i = 0; i < n; ++i) {
      if (passive[i]) continue;
      double gradient = h[i];
      for (std::size_t j = 0; j < n; ++j) gradient -= G[i * n + j] * w[j];
      if (gradient > best_gradient) {
        best_gradient = gradient;
        best = i;
      }
    }
    if (best == n) break;
    passive[best] = true;
    for (std::size_t inner = 0; inner < 3 * n; ++inner) {
      solve_passive();
      double step = 1;  // the largest step toward z that keeps w >= 0
      for (std::size_t i = 0; i < n; ++i)
        if (passive[i] && z[i] <= 0) step = std::min(step, w[i] / (w[i] - z[i]));
      for (std::size_t i = 0; i < n; ++i) w[i] += step * (z[i] - w[i]);
      if (step == 1) break;
      for (std::size_t i = 0; i < n; ++i)
        if (passive[i] && w[i] <= 0) {
          passive[i] = false;
          w[i] = 0;
        }
    }
  }
  return w;
}

}  // namespace mpmrom::dense
