// Empirical cubature of the samples' projection (ECSW, Farhat et al.): non-negative weights with which the samples'
// sums reproduce the all-point, mass-weighted sums of the projection over snapshots (rom/detail/snapshots.hpp), and
// the greedy choice of the samples that Lawson and Hanson's active set makes (docs/rom.md "Sample weights").
#include <cmath>
#include <stdexcept>
#include <vector>

#include "core/math/nnls.hpp"
#include "mpmrom/rom.hpp"
#include "rom/detail/snapshots.hpp"

namespace mpmrom {
namespace {

using impl::PointSnapshot;
using impl::SnapshotStream;

// The cubature's least-squares system in normal form over the candidate points: G = E^T E, h = E^T f, where E's
// column c holds candidate c's quantities at every snapshot (the upper triangle of J^T J, then J^T of each field)
// and f the all-point mass-weighted sums; each block's rows are scaled by its sums' norm, so that each counts as one
// relative misfit. E and f are kept for the misfits.
struct CubatureSystem {
  int r = 0;
  std::size_t rows = 0, columns = 0, per_snapshot = 0;
  std::vector<double> E, f, G, h;
  int block_of(std::size_t row) const {
    const std::size_t k = row % per_snapshot, matrix = std::size_t(r * (r + 1) / 2);
    return k < matrix ? 0 : 1 + int((k - matrix) / std::size_t(r));
  }
  int blocks() const { return 1 + int((per_snapshot - std::size_t(r * (r + 1) / 2)) / std::size_t(r)); }
};

void point_quantities(const PointSnapshot& snapshot, std::size_t p, int r, double* out) {  // p: the row
  const double* J = snapshot.J + p * 3 * std::size_t(r);
  int k = 0;
  for (int i = 0; i < r; ++i)
    for (int j = i; j < r; ++j) {
      double sum = 0;
      for (int d = 0; d < 3; ++d) sum += J[d * r + i] * J[d * r + j];
      out[k++] = sum;
    }
  for (const double* field : snapshot.fields)
    for (int i = 0; i < r; ++i) {
      double sum = 0;
      for (int d = 0; d < 3; ++d) sum += J[d * r + i] * field[p * 3 + d];
      out[k++] = sum;
    }
  if (snapshot.reduced != nullptr)
    for (int i = 0; i < r; ++i) out[k++] = snapshot.reduced[p * std::size_t(r) + std::size_t(i)];
}

CubatureSystem cubature_system(const Model& model, const SnapshotStream& snapshots,
                               const std::vector<int>& candidates) {
  CubatureSystem system;
  system.r = model.latent_dim;
  const int r = system.r;
  const std::size_t P = model.num_points(), C = candidates.size();
  std::vector<double> q;
  snapshots([&](const PointSnapshot& snapshot) {
    const std::size_t Q = std::size_t(r * (r + 1) / 2) + snapshot.blocks() * std::size_t(r);
    system.per_snapshot = Q;
    q.resize(Q);
    const std::size_t first = system.f.size();
    system.f.resize(first + Q, 0.0);
    system.E.resize((first + Q) * C, 0.0);
    for (std::size_t row = 0; row < snapshot.rows(P); ++row) {
      point_quantities(snapshot, row, r, q.data());
      const double m = snapshot.mass_scale * model.mass[snapshot.point(row)];
      for (std::size_t k = 0; k < Q; ++k) system.f[first + k] += m * q[k];
    }
    const std::vector<std::size_t> rows = snapshot.rows_of(candidates);
    for (std::size_t c = 0; c < C; ++c) {
      point_quantities(snapshot, rows[c], r, q.data());
      for (std::size_t k = 0; k < Q; ++k) system.E[(first + k) * C + c] = q[k];
    }
  });
  system.rows = system.f.size();
  system.columns = C;
  if (system.rows == 0) throw std::runtime_error("cubature: no snapshots to fit");
  std::vector<double> norm2(std::size_t(system.blocks()), 0.0);
  for (std::size_t row = 0; row < system.rows; ++row) norm2[system.block_of(row)] += system.f[row] * system.f[row];
  for (std::size_t row = 0; row < system.rows; ++row) {
    const double n2 = norm2[system.block_of(row)];
    const double scale = n2 > 0 ? 1 / std::sqrt(n2) : 0;
    system.f[row] *= scale;
    for (std::size_t c = 0; c < C; ++c) system.E[row * C + c] *= scale;
  }
  system.G.assign(C * C, 0.0);
  system.h.assign(C, 0.0);
  for (std::size_t row = 0; row < system.rows; ++row) {
    const double* e = &system.E[row * C];
    for (std::size_t a = 0; a < C; ++a) {
      if (e[a] == 0) continue;
      system.h[a] += e[a] * system.f[row];
      for (std::size_t b = 0; b < C; ++b) system.G[a * C + b] += e[a] * e[b];
    }
  }
  return system;
}

// The non-negative fit over the system's candidates (at most max_active positive, 0: any), with its relative
// misfits per block; keeps the candidates with w > 0 when positive_only, else every candidate in order.
CubatureFit solve(const CubatureSystem& system, const std::vector<int>& candidates, std::size_t max_active,
                  bool positive_only) {
  const std::vector<double> w = dense::nnls_normal(system.G, system.h, system.columns, max_active);
  CubatureFit fit;
  fit.misfits.assign(std::size_t(system.blocks()), 0.0);
  for (std::size_t row = 0; row < system.rows; ++row) {
    double e = -system.f[row];
    for (std::size_t c = 0; c < system.columns; ++c) e += system.E[row * system.columns + c] * w[c];
    fit.misfits[std::size_t(system.block_of(row))] += e * e;
  }
  for (double& m : fit.misfits) m = std::sqrt(m);
  for (std::size_t c = 0; c < candidates.size(); ++c)
    if (!positive_only || w[c] > 0) {
      fit.samples.push_back(candidates[c]);
      fit.weights.push_back(w[c]);
    }
  return fit;
}

}  // namespace

CubatureFit cubature_weights(const Model& model, const CubatureSnapshots& snapshots, const std::vector<int>& samples) {
  return solve(cubature_system(model, impl::snapshot_stream(model, snapshots), samples), samples, 0, false);
}

CubatureFit cubature_selection(const Model& model, const CubatureSnapshots& snapshots, std::size_t count) {
  const std::vector<int> candidates = impl::all_candidates(model, snapshots.max_candidates);
  return solve(cubature_system(model, impl::snapshot_stream(model, snapshots), candidates), candidates, count, true);
}

}  // namespace mpmrom
