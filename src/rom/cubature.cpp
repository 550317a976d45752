// Empirical cubature of the samples' projection (ECSW, Farhat et al.): non-negative weights with which the samples'
// sums reproduce the all-point, mass-weighted sums of the projection over snapshots (rom/detail/snapshots.hpp), and
// the greedy choice of the samples that Lawson and Hanson's active set makes (docs/rom.md "Sample weights").
#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "core/math/nnls.hpp"
#include "mpmrom/rom.hpp"
#include "rom/detail/snapshots.hpp"

namespace mpmrom {
namespace {

using impl::PointSnapshot;
using impl::SnapshotStream;

// A bound on the exchange passes over a count-limited active set: 4-7 reach a fixed point on the poke cylinder's
// fits of 15-30 samples, at about 0.4 s a pass for 15 samples among 1368 candidates.
constexpr int kExchangePasses = 20;
// A pass solves k x C subset fits of k unknowns, each up to k Cholesky factorisations of k^3 / 3: about k^5 C / 3
// operations (an upper bound: 30 samples among 1368 measured 3 s a pass). Above this budget (about 37 samples among
// 2048 candidates, 40 among 1368) the active set's choice is kept as it is.
constexpr double kExchangePassBudget = 5e10;

// The cubature's least-squares system over the candidate points, E w = f: E's column c holds candidate c's
// quantities at every snapshot (the upper triangle of J^T J, then J^T of each field, then the Galerkin force) and f
// the all-point mass-weighted sums; each block's rows are scaled by its sums' norm, so that each counts as one
// relative misfit. The fits form normal equations from the blocks and columns they take (normal_equations).
struct CubatureSystem {
  int r = 0;
  std::size_t rows = 0, columns = 0, per_snapshot = 0;
  std::vector<double> E, f;
  int block_of(std::size_t row) const {
    const std::size_t k = row % per_snapshot, matrix = std::size_t(r * (r + 1) / 2);
    return k < matrix ? 0 : 1 + int((k - matrix) / std::size_t(r));
  }
  int blocks() const { return 1 + int((per_snapshot - std::size_t(r * (r + 1) / 2)) / std::size_t(r)); }
};

// The row's quantities as a candidate, or (target) as a term of the all-point sums.
void point_quantities(const PointSnapshot& snapshot, std::size_t p, int r, bool target, double* out) {
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
  const double* reduced = target && snapshot.reduced_target != nullptr ? snapshot.reduced_target : snapshot.reduced;
  if (reduced != nullptr)
    for (int i = 0; i < r; ++i) out[k++] = reduced[p * std::size_t(r) + std::size_t(i)];
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
      point_quantities(snapshot, row, r, true, q.data());
      const double m = snapshot.mass_scale * model.mass[snapshot.point(row)];
      for (std::size_t k = 0; k < Q; ++k) system.f[first + k] += m * q[k];
    }
    const std::vector<std::size_t> rows = snapshot.rows_of(candidates);
    for (std::size_t c = 0; c < C; ++c) {
      point_quantities(snapshot, rows[c], r, false, q.data());
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
  return system;
}

// The normal equations G w = h of the system's rows in `blocks` (a mask by block) over the columns `columns`.
void normal_equations(const CubatureSystem& system, const std::vector<bool>& blocks,
                      const std::vector<std::size_t>& columns, std::vector<double>& G, std::vector<double>& h) {
  const std::size_t C = columns.size();
  G.assign(C * C, 0.0);
  h.assign(C, 0.0);
  for (std::size_t row = 0; row < system.rows; ++row) {
    if (!blocks[std::size_t(system.block_of(row))]) continue;
    const double* e = &system.E[row * system.columns];
    for (std::size_t a = 0; a < C; ++a) {
      const double ea = e[columns[a]];
      if (ea == 0) continue;
      h[a] += ea * system.f[row];
      for (std::size_t b = 0; b < C; ++b) G[a * C + b] += ea * e[columns[b]];
    }
  }
}

// The non-negative fit of the normal equations (G, h) (n unknowns) restricted to `subset`: its weights (one per
// subset entry) and the drop it brings to the squared misfit, 2 h.w - w.G w.
double subset_fit(const std::vector<double>& G, const std::vector<double>& h, std::size_t n,
                  const std::vector<std::size_t>& subset, std::vector<double>& w) {
  const std::size_t k = subset.size();
  std::vector<double> Gs(k * k), hs(k);
  for (std::size_t a = 0; a < k; ++a) {
    hs[a] = h[subset[a]];
    for (std::size_t b = 0; b < k; ++b) Gs[a * k + b] = G[subset[a] * n + subset[b]];
  }
  w = dense::nnls_normal(Gs, hs, k);
  double drop = 0;
  for (std::size_t a = 0; a < k; ++a) {
    double Gw = 0;
    for (std::size_t b = 0; b < k; ++b) Gw += Gs[a * k + b] * w[b];
    drop += 2 * hs[a] * w[a] - w[a] * Gw;
  }
  return drop;
}

// Exchange passes after the active set's greedy choice (which never revisits a point it took): each chosen unknown in
// turn is swapped for the unchosen one whose subset fit lowers the misfit most, until a pass swaps none (at most
// max_passes). Returns the subset's weights as a weight per unknown.
std::vector<double> refine_by_exchange(const std::vector<double>& G, const std::vector<double>& h, std::size_t n,
                                       std::vector<double> w, int max_passes) {
  std::vector<std::size_t> chosen;
  std::vector<bool> taken(n, false);
  for (std::size_t i = 0; i < n; ++i)
    if (w[i] > 0) chosen.push_back(i), taken[i] = true;
  std::vector<double> ws;
  double best = subset_fit(G, h, n, chosen, ws);
  for (int pass = 0; pass < max_passes; ++pass) {
    bool swapped = false;
    for (std::size_t slot = 0; slot < chosen.size(); ++slot) {
      std::size_t best_candidate = n;
      std::vector<std::size_t> trial = chosen;
      for (std::size_t c = 0; c < n; ++c) {
        if (taken[c]) continue;
        trial[slot] = c;
        const double drop = subset_fit(G, h, n, trial, ws);
        if (drop > best + 1e-10) best = drop, best_candidate = c;  // the targets have unit norm a block
      }
      if (best_candidate == n) continue;
      taken[chosen[slot]] = false;
      taken[best_candidate] = true;
      chosen[slot] = best_candidate;
      swapped = true;
    }
    if (!swapped) break;
  }
  subset_fit(G, h, n, chosen, ws);
  std::fill(w.begin(), w.end(), 0.0);
  for (std::size_t a = 0; a < chosen.size(); ++a) w[chosen[a]] = ws[a];
  return w;
}

// Non-negative weights over `columns` for the rows in `blocks` (at most max_active positive, 0: any), as a weight
// per system column (0 outside `columns`). When the limit cuts the active set short, exchange passes refine its
// choice within their budget (a fit that stops below the limit is the unconstrained optimum already).
std::vector<double> fit_blocks(const CubatureSystem& system, const std::vector<bool>& blocks,
                               const std::vector<std::size_t>& columns, std::size_t max_active) {
  std::vector<double> G, h;
  normal_equations(system, blocks, columns, G, h);
  std::vector<double> w = dense::nnls_normal(G, h, columns.size(), max_active);
  const double k = double(max_active), pass_cost = k * k * k * k * k * double(columns.size()) / 3;
  if (max_active > 0 && pass_cost <= kExchangePassBudget &&
      std::size_t(std::count_if(w.begin(), w.end(), [](double x) { return x > 0; })) >= max_active)
    w = refine_by_exchange(G, h, columns.size(), w, kExchangePasses);
  std::vector<double> all(system.columns, 0.0);
  for (std::size_t c = 0; c < columns.size(); ++c) all[columns[c]] = w[c];
  return all;
}

// The non-negative fit over the system's candidates (at most max_active positive, 0: any), with its relative
// misfits per block; keeps the candidates with a positive weight when positive_only, else every candidate in order.
// split: the last block (the Galerkin step's force) gets weights of its own, the active set chosen on it, and the
// mass matrix and momentum are then fitted on the same samples.
CubatureFit solve(const CubatureSystem& system, const std::vector<int>& candidates, std::size_t max_active,
                  bool positive_only, bool split) {
  const std::size_t blocks = std::size_t(system.blocks());
  std::vector<std::size_t> every(system.columns);
  std::iota(every.begin(), every.end(), 0);
  std::vector<double> w, force;
  if (!split) {
    w = fit_blocks(system, std::vector<bool>(blocks, true), every, max_active);
    force = w;
  } else {
    std::vector<bool> last(blocks, false), others(blocks, true);
    last.back() = true;
    others.back() = false;
    force = fit_blocks(system, last, every, max_active);
    std::vector<std::size_t> taken;
    for (std::size_t c = 0; c < system.columns; ++c)
      if (force[c] > 0 || !positive_only) taken.push_back(c);
    w = fit_blocks(system, others, taken, 0);
  }
  CubatureFit fit;
  fit.misfits.assign(blocks, 0.0);
  for (std::size_t row = 0; row < system.rows; ++row) {
    const std::size_t block = std::size_t(system.block_of(row));
    const std::vector<double>& weights = split && block + 1 == blocks ? force : w;
    double e = -system.f[row];
    for (std::size_t c = 0; c < system.columns; ++c) e += system.E[row * system.columns + c] * weights[c];
    fit.misfits[block] += e * e;
  }
  for (double& m : fit.misfits) m = std::sqrt(m);
  for (std::size_t c = 0; c < candidates.size(); ++c)
    if (!positive_only || force[c] > 0) {
      fit.samples.push_back(candidates[c]);
      fit.weights.push_back(w[c]);
      if (split) fit.force_weights.push_back(force[c]);
    }
  return fit;
}

// Whether the snapshots' force target is another step's (CubatureTarget::Grid): then fitted with weights of its own.
bool split_force(const CubatureSnapshots& snapshots) {
  return snapshots.data == nullptr && snapshots.settings.method == RomMethod::Galerkin &&
         snapshots.settings.cubature_target == CubatureTarget::Grid;
}

}  // namespace

CubatureFit cubature_weights(const Model& model, const CubatureSnapshots& snapshots, const std::vector<int>& samples) {
  return solve(cubature_system(model, impl::snapshot_stream(model, snapshots), samples), samples, 0, false,
               split_force(snapshots));
}

CubatureFit cubature_selection(const Model& model, const CubatureSnapshots& snapshots, std::size_t count) {
  const std::vector<int> candidates = impl::all_candidates(model, snapshots.max_candidates);
  return solve(cubature_system(model, impl::snapshot_stream(model, snapshots), candidates), candidates, count, true,
               split_force(snapshots));
}

}  // namespace mpmrom
