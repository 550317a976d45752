// Greedy sample selection on the projection itself (docs/rom.md "Sample selection"): the samples whose
// mass-weighted projection of each sub-step's velocity increment comes closest to the all-point one over snapshots,
// improved by exchanges, and optionally the weights that bring it closer still.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <utility>
#include <stdexcept>
#include <vector>

#include "core/math/cholesky.hpp"
#include "mpmrom/rom.hpp"
#include "rom/detail/snapshots.hpp"
#include "rom/kernels/manifold.hpp"  // max_latent_dim

namespace mpmrom {
namespace {

// Exchange passes after the greedy growth: measured on the poke cylinder, 5 to 6 passes reach a fixed point.
constexpr int max_exchange_passes = 20;

using impl::PointSnapshot;
using impl::SnapshotStream;

// Greedy selection on the projection itself: at each snapshot, the all-point mass-weighted projection of the
// sub-step's velocity increment, delta = A^-1 b (A = sum_p m_p J_p^T J_p, b = sum_p m_p J_p^T dv_p), against the
// samples' delta_S = A_S^-1 b_S; the error is the kinetic energy of the difference, (delta_S - delta)^T A (...).
struct IncrementSnapshots {
  int r = 0;
  std::size_t T = 0, C = 0;
  std::vector<double> A, delta;   // (T, r, r), (T, r): the all-point projection
  std::vector<double> J, dv;      // (T, C, 3, r), (T, C, 3): the candidates' rows
  std::vector<char> sensitivity;  // (T): whether snapshot t is a response to the latent state
};

IncrementSnapshots increment_snapshots(const Model& model, const SnapshotStream& snapshots,
                                       const std::vector<int>& candidates) {
  IncrementSnapshots set;
  set.r = model.latent_dim;
  const int r = set.r;
  const std::size_t P = model.num_points(), C = candidates.size(), rr = std::size_t(r * r);
  set.C = C;
  snapshots([&](const PointSnapshot& snapshot) {
    if (snapshot.fields.size() != 1 || snapshot.reduced != nullptr)
      throw std::invalid_argument(
          "greedy projection selection fits the grid step's velocity increments: it needs --cubature-snapshots "
          "reduced or states, and --method point or node");
    std::vector<double> A(rr, 0.0), b(std::size_t(r), 0.0);
    for (std::size_t p = 0; p < snapshot.rows(P); ++p)  // p: the row
      for (int d = 0; d < 3; ++d) {
        const double* row = snapshot.J + (p * 3 + std::size_t(d)) * std::size_t(r);
        const double m = snapshot.row_mass(p, model.mass);
        const double f = snapshot.fields[0][p * 3 + std::size_t(d)];
        for (int i = 0; i < r; ++i) {
          b[std::size_t(i)] += m * row[i] * f;
          for (int j = 0; j < r; ++j) A[std::size_t(i * r + j)] += m * row[i] * row[j];
        }
      }
    std::vector<double> L = A, delta = b;
    if (!dense::SerialCholesky(L.data(), r, r)) return;  // a degenerate snapshot says nothing
    dense::SerialCholeskySolve(L.data(), r, r, delta.data());
    set.A.insert(set.A.end(), A.begin(), A.end());
    set.sensitivity.push_back(snapshot.sensitivity);
    set.delta.insert(set.delta.end(), delta.begin(), delta.end());
    for (const std::size_t c : snapshot.rows_of(candidates)) {
      set.J.insert(set.J.end(), snapshot.J + c * 3 * std::size_t(r), snapshot.J + (c + 1) * 3 * std::size_t(r));
      set.dv.insert(set.dv.end(), snapshot.fields[0] + c * 3, snapshot.fields[0] + c * 3 + 3);
    }
    ++set.T;
  });
  if (set.T == 0) throw std::runtime_error("greedy projection selection: no snapshots");
  return set;
}

// Adds weight w times candidate c's three rows at snapshot t to one snapshot's normal equations A (r x r), b (r).
void add_point(const IncrementSnapshots& set, std::size_t t, std::size_t c, double w, double* A, double* b) {
  const int r = set.r;
  for (int d = 0; d < 3; ++d) {
    const double* row = &set.J[((t * set.C + c) * 3 + std::size_t(d)) * std::size_t(r)];
    const double f = w * set.dv[(t * set.C + c) * 3 + std::size_t(d)];
    for (int i = 0; i < r; ++i) {
      b[i] += row[i] * f;
      for (int j = 0; j < r; ++j) A[i * r + j] += w * row[i] * row[j];
    }
  }
}

// The same at every snapshot, into the per-snapshot normal equations (A, b).
void add_rows(const IncrementSnapshots& set, std::size_t c, double w, std::vector<double>& A, std::vector<double>& b) {
  const std::size_t r = std::size_t(set.r);
  for (std::size_t t = 0; t < set.T; ++t) add_point(set, t, c, w, &A[t * r * r], &b[t * r]);
}

// Snapshot t's samples' increment delta_S from their normal equations (A, b) plus candidate c with weight w (c < 0:
// none), into A (factored) and b (solved); a ridge of 1e-8 trace keeps the first, under-determined picks solvable.
bool solve_samples(const IncrementSnapshots& set, std::size_t t, const std::vector<double>& A_base,
                   const std::vector<double>& b_base, long c, double w, double* A, double* b) {
  const int r = set.r;
  const std::size_t rr = std::size_t(r * r);
  std::copy_n(&A_base[t * rr], rr, A);
  std::copy_n(&b_base[t * std::size_t(r)], r, b);
  if (c >= 0) add_point(set, t, std::size_t(c), w, A, b);
  double trace = 0;
  for (int i = 0; i < r; ++i) trace += A[i * r + i];
  for (int i = 0; i < r; ++i) A[i * r + i] += 1e-8 * trace / r + 1e-300;
  if (!dense::SerialCholesky(A, r, r)) return false;
  dense::SerialCholeskySolve(A, r, r, b);
  return true;
}

// The summed kinetic energy of (delta_S - delta) over the snapshots, with candidate c (weight w) added; the responses
// count `sensitivity` times (0: the increments alone).
double projection_error(const IncrementSnapshots& set, const std::vector<double>& A_base,
                        const std::vector<double>& b_base, long c, double w, double sensitivity) {
  const int r = set.r;
  double error = 0;
  for (std::size_t t = 0; t < set.T; ++t) {
    const double share = set.sensitivity[t] ? sensitivity : 1;
    if (share == 0) continue;
    double A[rom::max_latent_dim * rom::max_latent_dim], b[rom::max_latent_dim];
    if (!solve_samples(set, t, A_base, b_base, c, w, A, b)) return std::numeric_limits<double>::infinity();
    const double* full = &set.A[t * std::size_t(r * r)];
    const double* delta = &set.delta[t * std::size_t(r)];
    for (int i = 0; i < r; ++i)
      for (int j = 0; j < r; ++j) error += share * (b[i] - delta[i]) * full[i * r + j] * (b[j] - delta[j]);
  }
  return error;
}

// Gauss-Newton (Levenberg-Marquardt) on the log-weights w_s = m_s exp(u_s) of the chosen candidates, minimising
// projection_error: the weights that make the samples' projection closest to the all-point one.
std::vector<double> fit_weights(const IncrementSnapshots& set, const std::vector<std::size_t>& chosen,
                                std::vector<double> w, double sensitivity) {
  const int r = set.r;
  const std::size_t n = chosen.size(), R = set.T * std::size_t(r), rr = std::size_t(r * r);
  const auto sums = [&](const std::vector<double>& weights, std::vector<double>& A, std::vector<double>& b) {
    A.assign(set.T * rr, 0.0), b.assign(R, 0.0);
    for (std::size_t k = 0; k < n; ++k) add_rows(set, chosen[k], weights[k], A, b);
  };
  std::vector<double> A, b, G(n * n), g(n), Jres(R * n), res(R);
  sums(w, A, b);
  double error = projection_error(set, A, b, -1, 0, sensitivity), mu = 1e-3;
  for (int iteration = 0; iteration < 30; ++iteration) {
    // Residual L_t^T (delta_S - delta) and its derivative along u_k: L_t^T A_S^-1 w_k (b_k - A_k delta_S).
    for (std::size_t t = 0; t < set.T; ++t) {
      const double share = std::sqrt(set.sensitivity[t] ? sensitivity : 1.0);  // the residual's, squared in the error
      double LS[rom::max_latent_dim * rom::max_latent_dim], dS[rom::max_latent_dim],
          L[rom::max_latent_dim * rom::max_latent_dim];
      solve_samples(set, t, A, b, -1, 0, LS, dS);
      std::copy_n(&set.A[t * rr], rr, L);
      dense::SerialCholesky(L, r, r);
      const auto apply_Lt = [&](const double* x, double* out) {  // out = L^T x, L lower
        for (int i = 0; i < r; ++i) {
          out[i] = 0;
          for (int j = i; j < r; ++j) out[i] += L[j * r + i] * x[j];
        }
      };
      double e[rom::max_latent_dim];
      for (int i = 0; i < r; ++i) e[i] = share * (dS[i] - set.delta[t * std::size_t(r) + std::size_t(i)]);
      apply_Lt(e, &res[t * std::size_t(r)]);
      for (std::size_t k = 0; k < n; ++k) {
        double q[rom::max_latent_dim] = {0};
        for (int d = 0; d < 3; ++d) {
          const double* row = &set.J[((t * set.C + chosen[k]) * 3 + std::size_t(d)) * std::size_t(r)];
          double Jd = 0;
          for (int i = 0; i < r; ++i) Jd += row[i] * dS[i];
          const double f = set.dv[(t * set.C + chosen[k]) * 3 + std::size_t(d)] - Jd;
          for (int i = 0; i < r; ++i) q[i] += share * w[k] * row[i] * f;
        }
        dense::SerialCholeskySolve(LS, r, r, q);
        double out[rom::max_latent_dim];
        apply_Lt(q, out);
        for (int i = 0; i < r; ++i) Jres[(t * std::size_t(r) + std::size_t(i)) * n + k] = out[i];
      }
    }
    std::fill(G.begin(), G.end(), 0.0), std::fill(g.begin(), g.end(), 0.0);
    for (std::size_t row = 0; row < R; ++row)
      for (std::size_t a = 0; a < n; ++a) {
        g[a] -= Jres[row * n + a] * res[row];
        for (std::size_t c = 0; c < n; ++c) G[a * n + c] += Jres[row * n + a] * Jres[row * n + c];
      }
    bool improved = false;
    for (int tries = 0; tries < 8 && !improved; ++tries, mu *= 10) {
      std::vector<double> M = G, step = g, trial = w;
      for (std::size_t a = 0; a < n; ++a) M[a * n + a] += mu * (G[a * n + a] + 1e-12);
      if (!dense::SerialCholesky(M.data(), int(n), int(n))) continue;
      dense::SerialCholeskySolve(M.data(), int(n), int(n), step.data());
      for (std::size_t a = 0; a < n; ++a) trial[a] = w[a] * std::exp(std::clamp(step[a], -2.0, 2.0));
      std::vector<double> At, bt;
      sums(trial, At, bt);
      const double e = projection_error(set, At, bt, -1, 0, sensitivity);
      if (e < error) improved = true, error = e, w = trial, A = At, b = bt, mu = std::max(mu / 100, 1e-9);
    }
    if (!improved) break;
  }
  return w;
}

// The samples chosen so far, their normal equations per snapshot (masses as weights) and their error.
class SampleSet {
 public:
  SampleSet(const IncrementSnapshots& set, std::vector<double> masses, double sensitivity)
      : set_(set),
        masses_(std::move(masses)),
        sensitivity_(sensitivity),
        taken_(masses_.size(), false),
        A_(set.T * std::size_t(set.r * set.r), 0.0),
        b_(set.T * std::size_t(set.r), 0.0) {}
  const std::vector<std::size_t>& chosen() const { return chosen_; }
  const std::vector<double>& normal_matrices() const { return A_; }
  const std::vector<double>& right_hand_sides() const { return b_; }
  // Greedy: adds the candidate that lowers the error most, count times (or until none is left).
  void grow(std::size_t count) {
    while (chosen_.size() < count) {
      const long best = best_addition(error_);
      if (best < 0) return;
      chosen_.push_back(std::size_t(best));
      take(std::size_t(best), true);
    }
  }
  // One exchange pass: each sample in turn is swapped for the candidate that lowers the error most, if any does.
  // Returns whether a sample changed.
  bool exchange() {
    bool swapped = false;
    for (std::size_t& sample : chosen_) {
      take(sample, false);
      double error;
      const long best = best_addition(error);
      if (best >= 0 && error < error_ * (1 - 1e-9))
        swapped = swapped || std::size_t(best) != sample, sample = std::size_t(best), error_ = error;
      take(sample, true);
    }
    return swapped;
  }

 private:
  void take(std::size_t c, bool in) {
    taken_[c] = in;
    add_rows(set_, c, in ? masses_[c] : -masses_[c], A_, b_);
  }
  long best_addition(double& best_error) const {
    long best = -1;
    best_error = std::numeric_limits<double>::infinity();
    for (std::size_t c = 0; c < masses_.size(); ++c) {
      if (taken_[c]) continue;
      const double error = projection_error(set_, A_, b_, long(c), masses_[c], sensitivity_);
      if (error < best_error) best_error = error, best = long(c);
    }
    return best;
  }
  const IncrementSnapshots& set_;
  std::vector<double> masses_;
  double sensitivity_;
  std::vector<bool> taken_;
  std::vector<double> A_, b_;
  std::vector<std::size_t> chosen_;
  double error_ = std::numeric_limits<double>::infinity();
};

// sum_t delta_t^T A_t delta_t over the sub-steps' increments or (sensitivities) their responses: the all-point
// kinetic energy the errors are relative to.
double increment_energy(const IncrementSnapshots& set, bool sensitivities = false) {
  const std::size_t r = std::size_t(set.r);
  double energy = 0;
  for (std::size_t t = 0; t < set.T; ++t)
    if (bool(set.sensitivity[t]) == sensitivities)
      for (std::size_t i = 0; i < r; ++i)
        for (std::size_t j = 0; j < r; ++j)
          energy += set.delta[t * r + i] * set.A[(t * r + i) * r + j] * set.delta[t * r + j];
  return energy;
}

// Scales the responses so that their all-point energy is the increments': a sensitivity weight then weighs the two
// blocks' relative errors, whatever the units and the number of latent coordinates.
void normalize_sensitivities(IncrementSnapshots& set) {
  const double responses = increment_energy(set, true);
  if (!(responses > 0)) return;
  const double scale = std::sqrt(increment_energy(set) / responses);
  const std::size_t r = std::size_t(set.r), values = set.C * 3;
  for (std::size_t t = 0; t < set.T; ++t) {
    if (!set.sensitivity[t]) continue;
    for (std::size_t i = 0; i < r; ++i) set.delta[t * r + i] *= scale;
    for (std::size_t k = 0; k < values; ++k) set.dv[t * values + k] *= scale;
  }
}

}  // namespace

struct ProjectionSelector::Increments {
  std::vector<int> candidates;
  std::vector<double> masses;
  IncrementSnapshots set;
  double energy = 0;
};

ProjectionSelector::ProjectionSelector(const Model& model, const CubatureSnapshots& snapshots) {
  auto increments = std::make_shared<Increments>();
  increments->candidates = impl::all_candidates(model, snapshots.max_candidates).points;
  const std::vector<double>& weights = snapshots.settings.selection_sensitivities;
  // the responses of the grid methods' reduced sub-steps (other snapshots are refused below, as before the trials)
  const bool responses = std::any_of(weights.begin(), weights.end(), [](double w) { return w > 0; }) &&
                         snapshots.data == nullptr && snapshots.settings.method != RomMethod::Galerkin;
  increments->set =
      increment_snapshots(model, impl::snapshot_stream(model, snapshots, responses), increments->candidates);
  for (const int c : increments->candidates) increments->masses.push_back(model.mass[std::size_t(c)]);
  normalize_sensitivities(increments->set);
  increments->energy = increment_energy(increments->set);
  increments_ = std::move(increments);
}

CubatureFit ProjectionSelector::select(std::size_t count, bool fit, double sensitivity) const {
  const Increments& in = *increments_;
  const IncrementSnapshots& set = in.set;
  if (sensitivity > 0 && std::find(set.sensitivity.begin(), set.sensitivity.end(), 1) == set.sensitivity.end())
    throw std::logic_error("greedy projection: a sensitivity weight, but the snapshots hold no responses");
  SampleSet samples(set, in.masses, sensitivity);
  samples.grow(std::min(count, in.candidates.size()));
  for (int pass = 0; pass < max_exchange_passes && samples.exchange(); ++pass) {
  }
  CubatureFit selected;
  // The misfits are of the increments alone (with a sensitivity weight the search's objective is not theirs only).
  const auto misfit = [&](const std::vector<double>& A, const std::vector<double>& b) {
    return std::sqrt(projection_error(set, A, b, -1, 0, 0.0) / in.energy);
  };
  selected.misfits = {misfit(samples.normal_matrices(), samples.right_hand_sides())};
  for (const std::size_t c : samples.chosen())
    selected.samples.push_back(in.candidates[c]), selected.weights.push_back(in.masses[c]);
  if (fit) {
    selected.weights = fit_weights(set, samples.chosen(), selected.weights, sensitivity);
    std::vector<double> A(set.T * std::size_t(set.r * set.r), 0.0), b(set.T * std::size_t(set.r), 0.0);
    for (std::size_t k = 0; k < selected.weights.size(); ++k)
      add_rows(set, samples.chosen()[k], selected.weights[k], A, b);
    selected.misfits.push_back(misfit(A, b));
  }
  return selected;
}

CubatureFit greedy_projection_selection(const Model& model, const CubatureSnapshots& snapshots, std::size_t count) {
  return ProjectionSelector(model, snapshots)
      .select(count, fitted_weights(snapshots.settings) == SampleWeighting::Cubature, 0.0);
}

}  // namespace mpmrom
