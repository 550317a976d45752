// Empirical cubature of the samples' projection (ECSW, Farhat et al.): non-negative weights with which the samples'
// sums reproduce the all-point, mass-weighted sums of the projection over snapshots (rom/detail/snapshots.hpp), and
// the greedy choice of the samples that Lawson and Hanson's active set makes (docs/rom.md "Sample weights").
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <numeric>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/math/cholesky.hpp"
#include "core/math/nnls.hpp"
#include "mpmrom/rom.hpp"
#include "rom/detail/snapshots.hpp"

namespace mpmrom {
namespace {

using impl::PointSnapshot;
using impl::SnapshotStream;

// A bound on the exchange passes over a count-limited active set: 4-7 reach a fixed point on the poke cylinder's
// fits of 15-30 samples.
constexpr int kExchangePasses = 20;
// The exchange runs where k^5 C / 3 (k samples among C candidates) is within this budget, about 37 samples among
// 2048 candidates and 40 among 1368, where it was measured to help (15-30 samples). Above it the active set's choice
// is kept: on the poke cylinder, 60 samples among 1368 exchanged lowered the force misfit on the training snapshots
// from 0.68 % to 0.50 % but on the held-out run only from 1.49 % to 1.44 %, for six times the set-up (111 s against
// 17 s on 2 busy cores, SlotFits' bordered fits).
constexpr double kExchangePassBudget = 5e10;

// The cubature's least-squares system over the candidate points, E w = f: E's column c holds candidate c's
// quantities at every snapshot (the upper triangle of J^T J, then J^T of each field, then the Galerkin force) and f
// the all-point mass-weighted sums; each block's rows are scaled by its sums' norm, so that each counts as one
// relative misfit. The fits form normal equations from the blocks and columns they take (normal_equations).
struct CubatureSystem {
  int r = 0;
  std::size_t rows = 0, columns = 0, per_snapshot = 0;
  std::vector<double> E, f;
  std::vector<int> run_of_snapshot;  // PointSnapshot::run of each snapshot, in row order
  int run_of(std::size_t row) const { return run_of_snapshot[row / per_snapshot]; }
  int block_of(std::size_t row) const {
    const std::size_t k = row % per_snapshot, matrix = std::size_t(r * (r + 1) / 2);
    return k < matrix ? 0 : 1 + int((k - matrix) / std::size_t(r));
  }
  int blocks() const { return 1 + int((per_snapshot - std::size_t(r * (r + 1) / 2)) / std::size_t(r)); }
};

// The row's quantities: a candidate's column, and its term of the all-point sums.
void point_quantities(const PointSnapshot& snapshot, std::size_t p, int r, double* out) {
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
    system.run_of_snapshot.push_back(snapshot.run);
    q.resize(Q);
    const std::size_t first = system.f.size();
    system.f.resize(first + Q, 0.0);
    system.E.resize((first + Q) * C, 0.0);
    for (std::size_t row = 0; row < snapshot.rows(P); ++row) {
      point_quantities(snapshot, row, r, q.data());
      const double m = snapshot.row_mass(row, model.mass);
      for (std::size_t k = 0; k < Q; ++k) system.f[first + k] += m * q[k];
    }
    if (snapshot.reduced_target_sum != nullptr)  // the force block, last
      for (int k = 0; k < r; ++k)
        system.f[first + Q - std::size_t(r) + std::size_t(k)] = snapshot.reduced_target_sum[k];
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
  return system;
}

// The normal equations G w = h of the system's rows in `blocks` (a mask by block) over the columns `columns`; with
// held_run >= 0, of that training run's rows alone.
struct NormalEquations {
  std::vector<double> G, h;
  NormalEquations& operator-=(const NormalEquations& other) {
    for (std::size_t i = 0; i < G.size(); ++i) G[i] -= other.G[i];
    for (std::size_t i = 0; i < h.size(); ++i) h[i] -= other.h[i];
    return *this;
  }
};
NormalEquations normal_equations(const CubatureSystem& system, const std::vector<bool>& blocks,
                                 const std::vector<std::size_t>& columns, int held_run = -1) {
  const std::size_t C = columns.size();
  NormalEquations ne{std::vector<double>(C * C, 0.0), std::vector<double>(C, 0.0)};
  for (std::size_t row = 0; row < system.rows; ++row) {
    if (!blocks[std::size_t(system.block_of(row))] || (held_run >= 0 && system.run_of(row) != held_run)) continue;
    const double* e = &system.E[row * system.columns];
    for (std::size_t a = 0; a < C; ++a) {
      const double ea = e[columns[a]];
      if (ea == 0) continue;
      ne.h[a] += ea * system.f[row];
      for (std::size_t b = 0; b < C; ++b) ne.G[a * C + b] += ea * e[columns[b]];
    }
  }
  return ne;
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

// The subset fits of one exchange slot, the chosen unknowns but the slot's (`others`) with each candidate in turn:
// the others' normal matrix (plus nnls_normal's ridge, 1e-12 of its largest diagonal entry) factored once, each
// candidate bordered onto the factor in O(k^2) instead of an active-set fit of up to k factorisations. Where the
// bordered least-squares weights are all positive they are the subset's non-negative fit (the unconstrained
// minimiser is feasible, so it is the constrained one), equal to subset_fit's to rounding. Otherwise their drop
// bounds the non-negative fit's from above, so a candidate whose bound does not beat the slot's best drop is passed
// over without its fit; the rest, and any whose bordered matrix is not positive definite, take subset_fit. On the
// poke cylinder's 30 samples among 1368 candidates, of 441,540 candidate fits 39 % were all positive, 61 % passed
// over and 129 took the active-set fit.
class SlotFits {
 public:
  SlotFits(const std::vector<double>& G, const std::vector<double>& h, std::size_t n, std::vector<std::size_t> others)
      : G_(G), h_(h), n_(n), others_(std::move(others)), m_(others_.size()), L_(m_ * m_), u_(m_) {
    double diagonal = 0;
    for (const std::size_t i : others_) diagonal = std::max(diagonal, G[i * n + i]);
    ridge_ = 1e-12 * diagonal;
    for (std::size_t a = 0; a < m_; ++a) {
      u_[a] = h[others_[a]];
      for (std::size_t b = 0; b < m_; ++b) L_[a * m_ + b] = G[others_[a] * n + others_[b]] + (a == b ? ridge_ : 0);
    }
    factored_ = m_ > 0 && dense::SerialCholesky(L_.data(), int(m_), int(m_));
    for (std::size_t a = 0; factored_ && a < m_; ++a) {  // u = L^-1 h_others, shared by every candidate
      for (std::size_t k = 0; k < a; ++k) u_[a] -= L_[a * m_ + k] * u_[k];
      u_[a] /= L_[a * m_ + a];
    }
  }

  // The drop in the squared misfit (2 h.w - w.G w) of the fit over the others and candidate c, or an upper bound
  // of it not above `threshold`.
  double drop(std::size_t c, double threshold) {
    if (factored_) {
      y_.resize(m_);
      for (std::size_t a = 0; a < m_; ++a) {  // y = L^-1 G(others, c)
        double s = G_[others_[a] * n_ + c];
        for (std::size_t k = 0; k < a; ++k) s -= L_[a * m_ + k] * y_[k];
        y_[a] = s / L_[a * m_ + a];
      }
      double d = G_[c * n_ + c] + ridge_, uc = h_[c];
      for (std::size_t a = 0; a < m_; ++a) d -= y_[a] * y_[a], uc -= y_[a] * u_[a];
      if (d > 0) {
        const double lc = std::sqrt(d), wc = uc / lc / lc;
        x_.resize(m_);
        bool positive = wc > 0;
        for (std::size_t a = m_; a-- > 0;) {  // L^T x_others = u - y w_c
          double s = u_[a] - y_[a] * wc;
          for (std::size_t k = a + 1; k < m_; ++k) s -= L_[k * m_ + a] * x_[k];
          x_[a] = s / L_[a * m_ + a];
          positive = positive && x_[a] > 0;
        }
        const double unconstrained = bordered_drop(c, wc);
        if (positive || unconstrained <= threshold) return unconstrained;
      }
    }
    std::vector<std::size_t> subset = others_;
    subset.push_back(c);
    std::vector<double> unused;
    return subset_fit(G_, h_, n_, subset, unused);
  }

 private:
  double bordered_drop(std::size_t c, double wc) const {
    double drop = 2 * h_[c] * wc - wc * wc * G_[c * n_ + c];
    for (std::size_t a = 0; a < m_; ++a) {
      double Gw = G_[others_[a] * n_ + c] * wc;
      for (std::size_t b = 0; b < m_; ++b) Gw += G_[others_[a] * n_ + others_[b]] * x_[b];
      drop += 2 * h_[others_[a]] * x_[a] - x_[a] * Gw - x_[a] * G_[others_[a] * n_ + c] * wc;
    }
    return drop;
  }

  const std::vector<double>& G_;
  const std::vector<double>& h_;
  std::size_t n_;
  std::vector<std::size_t> others_;
  std::size_t m_;
  std::vector<double> L_, u_, y_, x_;
  double ridge_ = 0;
  bool factored_ = false;
};

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
      std::vector<std::size_t> others = chosen;
      others.erase(others.begin() + std::ptrdiff_t(slot));
      SlotFits fits(G, h, n, std::move(others));
      for (std::size_t c = 0; c < n; ++c) {
        if (taken[c]) continue;
        const double drop = fits.drop(c, best + 1e-10);
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

// Non-negative weights of the normal equations over `columns` (at most max_active positive, 0: any), as a weight per
// system column (0 outside `columns`). When the limit cuts the active set short, exchange passes refine its choice
// within their budget (a fit that stops below the limit is the unconstrained optimum already).
std::vector<double> fit_normal(const CubatureSystem& system, const NormalEquations& ne,
                               const std::vector<std::size_t>& columns, std::size_t max_active) {
  std::vector<double> w = dense::nnls_normal(ne.G, ne.h, columns.size(), max_active);
  const double k = double(max_active), pass_cost = k * k * k * k * k * double(columns.size()) / 3;
  if (max_active > 0 && pass_cost <= kExchangePassBudget &&
      std::size_t(std::count_if(w.begin(), w.end(), [](double x) { return x > 0; })) >= max_active)
    w = refine_by_exchange(ne.G, ne.h, columns.size(), w, kExchangePasses);
  std::vector<double> all(system.columns, 0.0);
  for (std::size_t c = 0; c < columns.size(); ++c) all[columns[c]] = w[c];
  return all;
}

// The training run held out to validate the fit: the last one, when the snapshots come from several (-1: one run).
int held_out_run(const CubatureSystem& system) {
  const auto [low, high] = std::minmax_element(system.run_of_snapshot.begin(), system.run_of_snapshot.end());
  return *low == *high ? -1 : *high;
}

// The weights (mass and momentum blocks) and force weights (the last block's own when split) of a fit, and the same
// fitted without the held-out run's rows.
struct BlockWeights {
  std::vector<double> w, force;
};

// The fit of solve(), and with held_run >= 0 the same fit without that run's rows: its normal equations are the
// whole system's minus the run's own (one pass over that run's rows, not all), then the active set and exchange
// passes run a second time.
std::pair<BlockWeights, BlockWeights> fit_weights(const CubatureSystem& system, std::size_t max_active,
                                                  bool positive_only, bool split, int held_run) {
  const std::size_t blocks = std::size_t(system.blocks());
  std::vector<std::size_t> every(system.columns);
  std::iota(every.begin(), every.end(), 0);
  std::vector<bool> all(blocks, true), last(blocks, false), others(blocks, true);
  last.back() = true;
  others.back() = false;
  const std::vector<bool>& first_blocks = split ? last : all;
  const NormalEquations first = normal_equations(system, first_blocks, every);
  // The mass and momentum blocks over the force fit's samples (split: weights of their own, few columns).
  const auto complete = [&](std::vector<double> force, int without) {
    if (!split) return BlockWeights{force, force};
    std::vector<std::size_t> taken;
    for (std::size_t c = 0; c < system.columns; ++c)
      if (force[c] > 0 || !positive_only) taken.push_back(c);
    NormalEquations rest = normal_equations(system, others, taken);
    if (without >= 0) rest -= normal_equations(system, others, taken, without);
    return BlockWeights{fit_normal(system, rest, taken, 0), std::move(force)};
  };
  BlockWeights fitted = complete(fit_normal(system, first, every, max_active), -1), validation;
  if (held_run >= 0) {
    NormalEquations without = first;
    without -= normal_equations(system, first_blocks, every, held_run);
    validation = complete(fit_normal(system, without, every, max_active), held_run);
  }
  return {std::move(fitted), std::move(validation)};
}

// Relative misfits per block of the weights over the rows of run `only` (-1: every row).
std::vector<double> block_misfits(const CubatureSystem& system, const BlockWeights& weights, bool split, int only) {
  const std::size_t blocks = std::size_t(system.blocks());
  std::vector<double> error(blocks, 0.0), norm(blocks, 0.0);
  for (std::size_t row = 0; row < system.rows; ++row) {
    if (only >= 0 && system.run_of(row) != only) continue;
    const std::size_t block = std::size_t(system.block_of(row));
    const std::vector<double>& w = split && block + 1 == blocks ? weights.force : weights.w;
    double e = -system.f[row];
    for (std::size_t c = 0; c < system.columns; ++c) e += system.E[row * system.columns + c] * w[c];
    error[block] += e * e;
    norm[block] += system.f[row] * system.f[row];
  }
  for (std::size_t b = 0; b < blocks; ++b) error[b] = norm[b] > 0 ? std::sqrt(error[b] / norm[b]) : 0.0;
  return error;
}

// The non-negative fit over the system's candidates (at most max_active positive, 0: any), with its relative
// misfits per block; keeps the candidates with a positive weight when positive_only, else every candidate in order.
// split: the last block (the Galerkin step's force) gets weights of its own, the active set chosen on it, and the
// mass matrix and momentum are then fitted on the same samples. With snapshots from several training runs, the
// same fit without the last run gives the held-out misfits over that run.
CubatureFit solve(const CubatureSystem& system, const std::vector<int>& candidates, std::size_t max_active,
                  bool positive_only, bool split) {
  const int held_run = held_out_run(system);
  const auto [fitted, validation] = fit_weights(system, max_active, positive_only, split, held_run);
  CubatureFit fit;
  fit.misfits = block_misfits(system, fitted, split, -1);
  if (held_run >= 0) fit.held_out_misfits = block_misfits(system, validation, split, held_run);
  for (std::size_t c = 0; c < candidates.size(); ++c)
    if (!positive_only || fitted.force[c] > 0) {
      fit.samples.push_back(candidates[c]);
      fit.weights.push_back(fitted.w[c]);
      if (split) fit.force_weights.push_back(fitted.force[c]);
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
  const std::vector<int> candidates = impl::all_candidates(model, snapshots.max_candidates).points;
  return solve(cubature_system(model, impl::snapshot_stream(model, snapshots), candidates), candidates, count, true,
               split_force(snapshots));
}

}  // namespace mpmrom
