// Which material points the reduced model samples: spread over the regions of the scene (region), at random (random),
// or greedily by the error of the projected training velocities (greedy).
#include <algorithm>
#include <cstdint>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/math/cholesky.hpp"
#include "core/math/splitmix64.hpp"
#include "mpmrom/rom.hpp"
#include "rom/detail/decoder.hpp"
#include "rom/detail/training_frames.hpp"
#include "rom/kernels/manifold.hpp"  // max_latent_dim

namespace mpmrom {
namespace {

// Farthest-point order within a group of points, starting from the one nearest the group's centroid: spreads a few
// samples over the group.
std::vector<int> farthest_points(const std::vector<double>& X, const std::vector<int>& group, std::size_t count) {
  std::vector<int> chosen;
  if (group.empty() || count == 0) return chosen;
  double c[3] = {0, 0, 0};
  for (const int p : group)
    for (int d = 0; d < 3; ++d) c[d] += X[3 * p + d] / double(group.size());
  const auto dist2 = [&](int p, const double* y) {
    double s = 0;
    for (int d = 0; d < 3; ++d) s += (X[3 * p + d] - y[d]) * (X[3 * p + d] - y[d]);
    return s;
  };
  int first = group[0];
  for (const int p : group)
    if (dist2(p, c) < dist2(first, c)) first = p;
  chosen.push_back(first);
  std::vector<double> nearest(group.size(), std::numeric_limits<double>::infinity());
  while (chosen.size() < std::min(count, group.size())) {
    const double* last = &X[3 * chosen.back()];
    std::size_t best = 0;
    for (std::size_t g = 0; g < group.size(); ++g) {
      nearest[g] = std::min(nearest[g], dist2(group[g], last));
      if (nearest[g] > nearest[best]) best = g;
    }
    chosen.push_back(group[best]);
  }
  return chosen;
}

std::vector<int> region_samples(const Model& model, const Scene& scene, std::size_t count) {
  // The paper's rule: where the force acts, where the body is held (near a Dirichlet region), and the free rest.
  const std::size_t P = model.num_points();
  std::vector<int> loaded, held, free;
  for (std::size_t p = 0; p < P; ++p) {
    const Vec3d X{model.X[3 * p], model.X[3 * p + 1], model.X[3 * p + 2]};
    bool in_force = false, near_held = false;
    for (const auto& f : scene.forces) in_force = in_force || f.region.contains(X);
    for (const auto& d : scene.dirichlet) {
      AxisBox grown = d.region;  // nodes of the region reach points within 1.5 cells
      for (int k = 0; k < 3; ++k) {
        grown.lo[k] -= 1.5 * scene.dx;
        grown.hi[k] += 1.5 * scene.dx;
      }
      near_held = near_held || grown.contains(X);
    }
    (in_force ? loaded : near_held ? held : free).push_back(int(p));
  }
  std::vector<std::vector<int>*> groups{&loaded, &held, &free};
  std::vector<int> chosen;
  std::size_t remaining = count;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const std::size_t share = g + 1 == groups.size() ? remaining : std::min(remaining, count / 3);
    const auto picked = farthest_points(model.X, *groups[g], share);
    chosen.insert(chosen.end(), picked.begin(), picked.end());
    remaining -= picked.size();
  }
  if (remaining > 0) {  // small groups: fill from everything not yet taken
    std::vector<int> rest;
    std::vector<bool> taken(P, false);
    for (const int p : chosen) taken[p] = true;
    for (std::size_t p = 0; p < P; ++p)
      if (!taken[p]) rest.push_back(int(p));
    const auto picked = farthest_points(model.X, rest, remaining);
    chosen.insert(chosen.end(), picked.begin(), picked.end());
  }
  return chosen;
}

// What the greedy selection fits: at T snapshots, the Jacobians Jh (T, S, 3, r) and full-order velocities V (T, S, 3)
// of S candidates, which are also the points whose projected velocity error is measured.
struct GreedyFit {
  int r;
  std::size_t T, S;
  std::vector<int> subset;
  std::vector<double> Jh, V;
};

GreedyFit greedy_fit(const Model& model, const TrainingData& data,
                     const std::vector<impl::TrainingFrame>& picked_frames) {
  const int r = model.latent_dim;
  // The points the training runs hold: every point, or those they were read at (their point_ids, the model's ids).
  const std::vector<std::size_t>& held = data.train.runs.front().point_ids;
  const std::size_t P = data.train.runs.front().num_points;
  const std::size_t T = picked_frames.size();
  // Candidates: about 512 of the held points spread evenly; subset names them by the model's ids.
  std::vector<std::size_t> local;
  std::vector<int> subset;
  for (std::size_t p = 0; p < P; p += std::max<std::size_t>(1, P / 512)) {
    local.push_back(p);
    subset.push_back(int(held.empty() ? p : held[p]));
  }
  const std::size_t S = subset.size();
  std::vector<double> Xs(S * 3);
  for (std::size_t s = 0; s < S; ++s) std::copy_n(&model.X[std::size_t(subset[s]) * 3], 3, &Xs[s * 3]);
  // Jacobians of the subset at the chosen codes.
  std::vector<double> codes;
  for (const auto& f : picked_frames)
    codes.insert(codes.end(), model.codes.begin() + f.code * r, model.codes.begin() + (f.code + 1) * r);
  std::vector<double> Jh = impl::decoder_jacobians(model, Xs, codes);
  std::vector<double> V(T * S * 3);
  for (std::size_t t = 0; t < T; ++t) {
    const Snapshot& run = data.train.runs[picked_frames[t].run];
    for (std::size_t s = 0; s < S; ++s)
      std::copy_n(run.v.begin() + (picked_frames[t].frame * P + local[s]) * 3, 3, V.begin() + (t * S + s) * 3);
  }
  return {r, T, S, std::move(subset), std::move(Jh), std::move(V)};
}

// Error of a sample set: residual of the subset's velocities after the projection, over the chosen snapshots, for the
// points whose normal equations are (A_base, b_base) (T of each) and candidate c.
double candidate_error(const GreedyFit& fit, const std::vector<double>& A_base, const std::vector<double>& b_base,
                       std::size_t c) {
  const int r = fit.r;
  const std::size_t T = fit.T, S = fit.S;
  const std::vector<double>&Jh = fit.Jh, &V = fit.V;
  double error = 0;
  for (std::size_t t = 0; t < T; ++t) {
    double A[rom::max_latent_dim * rom::max_latent_dim], b[rom::max_latent_dim];
    std::copy_n(&A_base[t * r * r], r * r, A);
    std::copy_n(&b_base[t * r], r, b);
    for (int k = 0; k < 3; ++k) {
      const double* row = &Jh[((t * S + c) * 3 + k) * r];
      for (int i = 0; i < r; ++i) {
        b[i] += row[i] * V[(t * S + c) * 3 + k];
        for (int j = 0; j < r; ++j) A[i * r + j] += row[i] * row[j];
      }
    }
    double trace = 0;
    for (int i = 0; i < r; ++i) trace += A[i * r + i];
    for (int i = 0; i < r; ++i) A[i * r + i] += 1e-8 * trace / r + 1e-300;
    if (!dense::SerialCholesky(A, r, r)) return std::numeric_limits<double>::infinity();
    dense::SerialCholeskySolve(A, r, r, b);
    for (std::size_t p = 0; p < S; ++p)
      for (int k = 0; k < 3; ++k) {
        const double* row = &Jh[((t * S + p) * 3 + k) * r];
        double v = 0;
        for (int i = 0; i < r; ++i) v += row[i] * b[i];
        const double e = v - V[(t * S + p) * 3 + k];
        error += e * e;
      }
  }
  return error;
}

// Greedy, error-driven: repeatedly adds the point whose velocities, projected with the others' onto the tangent
// space (the ROM's projection step), best reproduce the full-order velocities of about 512 points spread over the
// body, over a spread of training snapshots. A tiny ridge keeps the first (under-determined) steps solvable.
std::vector<int> greedy_samples(const Model& model, const TrainingData& data, std::size_t count) {
  const GreedyFit fit = greedy_fit(model, data, impl::training_frames(model, data, 24));
  const int r = fit.r;
  const std::size_t T = fit.T, S = fit.S;
  std::vector<double> A_base(T * r * r, 0.0), b_base(T * r, 0.0);
  std::vector<int> chosen;
  std::vector<bool> taken(S, false);
  for (std::size_t step = 0; step < count; ++step) {
    double best_error = std::numeric_limits<double>::infinity();
    int best = -1;
    for (std::size_t c = 0; c < S; ++c) {
      if (taken[c]) continue;
      const double error = candidate_error(fit, A_base, b_base, c);
      if (error < best_error) {
        best_error = error;
        best = int(c);
      }
    }
    if (best < 0) break;
    chosen.push_back(fit.subset[std::size_t(best)]);
    taken[std::size_t(best)] = true;
    for (std::size_t t = 0; t < T; ++t)
      for (int k = 0; k < 3; ++k) {
        const double* row = &fit.Jh[((t * S + std::size_t(best)) * 3 + k) * r];
        for (int i = 0; i < r; ++i) {
          b_base[t * r + i] += row[i] * fit.V[(t * S + std::size_t(best)) * 3 + k];
          for (int j = 0; j < r; ++j) A_base[t * r * r + i * r + j] += row[i] * row[j];
        }
      }
  }
  return chosen;
}

}  // namespace

std::vector<int> select_samples(const Model& model, const Scene& scene, const RomSettings& settings,
                                const TrainingData* data) {
  const std::size_t P = model.num_points();
  if (settings.samples == 0 || std::size_t(settings.samples) >= P) {
    std::vector<int> all(P);
    std::iota(all.begin(), all.end(), 0);
    return all;
  }
  const std::size_t count = std::size_t(settings.samples);
  switch (settings.selection) {
    case SampleSelection::Region: return region_samples(model, scene, count);
    case SampleSelection::Random: {
      std::vector<int> order(P);
      std::iota(order.begin(), order.end(), 0);
      std::uint64_t state = settings.seed;
      for (std::size_t i = P - 1; i > 0; --i) std::swap(order[i], order[splitmix64_next(state) % (i + 1)]);
      order.resize(count);
      return order;
    }
    case SampleSelection::Cubature:
      return cubature_selection(model, cubature_snapshots(scene, settings, data), count).samples;
    case SampleSelection::GreedyProjection:
      return greedy_projection_selection(model, cubature_snapshots(scene, settings, data), count).samples;
    case SampleSelection::Greedy:
      if (data != nullptr && !data->train.runs.empty()) return greedy_samples(model, *data, count);
      if (model.sample_ranking.empty())
        throw std::invalid_argument(
            "greedy sample selection: the model stores no sample ranking (it was trained "
            "by an older mpmrom); pass --data SWEEP_DIR or use --selection region");
      if (model.sample_ranking.size() < count)
        throw std::invalid_argument("greedy sample selection: the model ranks " +
                                    std::to_string(model.sample_ranking.size()) + " sample points, " +
                                    std::to_string(count) + " were asked for; pass --data SWEEP_DIR for more");
      return {model.sample_ranking.begin(), model.sample_ranking.begin() + std::ptrdiff_t(count)};
  }
  return {};
}

std::vector<std::int64_t> rank_samples_greedily(const Model& model, const TrainingData& data, std::size_t count) {
  const auto chosen = greedy_samples(model, data, std::min(count, model.num_points()));
  return {chosen.begin(), chosen.end()};
}

}  // namespace mpmrom
