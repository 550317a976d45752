#include "mpmrom/rom.hpp"

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "fom/fom.hpp"
#include "core/checked_integer.hpp"
#include "manifold/device_data.hpp"
#include "rom/detail/rom_stepper.hpp"
#include "rom/kernels/projection.hpp"
#include "rom/kernels/sources.hpp"
#include "rom/kernels/transfer.hpp"
#include "core/parallel.hpp"
#include "scene/sampling.hpp"
#include "manifold/trainer.hpp"

namespace mpmrom {
namespace {

using ExecutionSpace = Kokkos::DefaultExecutionSpace;
using MemorySpace = ExecutionSpace::memory_space;
using Vector = impl::DeviceVector;
using Matrix = impl::DeviceMatrix;
using Cube = impl::DeviceCube;
using Quad = impl::DeviceQuad;
using Clock = std::chrono::steady_clock;
using impl::download;
using impl::upload;
using impl::upload_indices;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// Positions of every reference point for every training code of the model: (codes, points, 3).
std::vector<double> training_positions(const Model& model) {
  const nn::MlpLayout layout = model.layout();
  const Vector params = upload<Vector>("mpmrom::rom::params", model.weights, layout.num_params);
  const auto mlp = impl::device_mlp(model, params);
  const std::size_t P = model.num_points(), C = model.num_codes();
  const Matrix X = upload<Matrix>("mpmrom::rom::X", model.X, P, 3);
  const Matrix codes = upload<Matrix>("mpmrom::rom::codes", model.codes, C, model.latent_dim);
  Cube g("mpmrom::rom::training_positions", C, P, 3);
  nn::evaluate(ExecutionSpace(), mlp, nn::PointsView<real_t, MemorySpace>(X), nn::CodesView<real_t, MemorySpace>(codes),
               g);
  return download(g);
}

// The grid nodes within reach of a point at x: the union of its quadratic stencils over x +- margin cells, per axis
// [lo, hi] node indices.
void reach(const GridGeometry<real_t>& grid, const double* x, double margin, int lo[3], int hi[3]) {
  for (int d = 0; d < 3; ++d) {
    const double xi = (x[d] - grid.origin[d]) / grid.dx;
    lo[d] = std::max(0, int(std::floor(xi - 0.5 - margin)));
    hi[d] = std::min(grid.dims[d] - 1, int(std::floor(xi - 0.5 + margin)) + 2);
  }
}

template <class Visit>
void for_each_node(const GridGeometry<real_t>& grid, const int lo[3], const int hi[3], Visit&& visit) {
  for (int i = lo[0]; i <= hi[0]; ++i)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int k = lo[2]; k <= hi[2]; ++k) visit(grid.index(i, j, k));
}

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

// splitmix64: a seeded stream that is the same on every platform (std::shuffle's is not).
std::uint64_t next_random(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
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

// Greedy, error-driven: repeatedly adds the point whose velocities, projected with the others' onto the tangent
// space (the ROM's projection step), best reproduce the full-order velocities of about 512 points spread over the
// body, over a spread of training snapshots. A tiny ridge keeps the first (under-determined) steps solvable.
std::vector<int> greedy_samples(const Model& model, const TrainingData& data, std::size_t count) {
  const int r = model.latent_dim;
  const std::size_t P = model.num_points();
  // Snapshots: model codes whose run is among the loaded training runs, about 24 spread over all of them.
  // Runs are matched by file name: the model records the paths it was trained from, which may have moved since.
  const auto file_name = [](const std::string& path) { return std::filesystem::path(path).filename().string(); };
  std::map<std::string, std::size_t> run_index;
  for (std::size_t i = 0; i < data.train.files.size(); ++i) run_index[file_name(data.train.files[i])] = i;
  struct Frame {
    std::size_t code, run, frame;
  };
  std::vector<Frame> frames;
  for (std::size_t c = 0; c < model.num_codes(); ++c) {
    const auto it = run_index.find(file_name(model.runs.at(std::size_t(model.code_run[c]))));
    if (it == run_index.end()) continue;
    const Snapshot& run = data.train.runs[it->second];
    for (std::size_t f = 0; f < run.num_frames; ++f)
      if (std::fabs(run.time[f] - model.code_time[c]) <= 1e-9 * std::max(1.0, run.time.back()))
        frames.push_back({c, it->second, f});
  }
  if (frames.empty())
    throw std::runtime_error("greedy selection: none of the model's training runs is among the given --data runs");
  std::vector<Frame> picked_frames;
  const std::size_t stride = std::max<std::size_t>(1, frames.size() / 24);
  for (std::size_t i = stride / 2; i < frames.size(); i += stride) picked_frames.push_back(frames[i]);
  const std::size_t T = picked_frames.size();
  // Candidates, which are also the points whose projected velocity error is measured: about 512 spread evenly.
  std::vector<int> subset;
  for (std::size_t p = 0; p < P; p += std::max<std::size_t>(1, P / 512)) subset.push_back(int(p));
  const std::size_t S = subset.size();
  std::vector<double> Xs(S * 3);
  for (std::size_t s = 0; s < S; ++s) std::copy_n(&model.X[std::size_t(subset[s]) * 3], 3, &Xs[s * 3]);
  // Jacobians of the subset at the chosen codes.
  std::vector<double> codes;
  for (const auto& f : picked_frames)
    codes.insert(codes.end(), model.codes.begin() + f.code * r, model.codes.begin() + (f.code + 1) * r);
  const nn::MlpLayout layout = model.layout();
  const Vector params = upload<Vector>("mpmrom::rom::params", model.weights, layout.num_params);
  const auto mlp = impl::device_mlp(model, params);
  Cube g("mpmrom::rom::greedy_g", T, S, 3), no_velocity;
  Quad F("mpmrom::rom::greedy_F", T, S, 3, 3), J("mpmrom::rom::greedy_J", T, S, 3, r);
  nn::evaluate_with_jacobians(ExecutionSpace(), mlp, nn::PointsView<real_t, MemorySpace>(upload<Matrix>("X", Xs, S, 3)),
                              nn::CodesView<real_t, MemorySpace>(upload<Matrix>("codes", codes, T, r)),
                              nn::CodesView<real_t, MemorySpace>(), g, F, J, no_velocity);
  const std::vector<double> Jh = download(J);
  std::vector<double> V(T * S * 3);
  for (std::size_t t = 0; t < T; ++t) {
    const Snapshot& run = data.train.runs[picked_frames[t].run];
    for (std::size_t s = 0; s < S; ++s)
      std::copy_n(run.v.begin() + (picked_frames[t].frame * P + std::size_t(subset[s])) * 3, 3, V.begin() + (t * S + s) * 3);
  }
  // Error of a sample set: residual of the subset's velocities after the projection, over the chosen snapshots.
  std::vector<double> A_base(T * r * r, 0.0), b_base(T * r, 0.0);
  std::vector<int> chosen;
  std::vector<bool> taken(S, false);
  for (std::size_t step = 0; step < count; ++step) {
    double best_error = std::numeric_limits<double>::infinity();
    int best = -1;
    for (std::size_t c = 0; c < S; ++c) {
      if (taken[c]) continue;
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
        if (!dense::SerialCholesky(A, r, r)) {
          error = std::numeric_limits<double>::infinity();
          break;
        }
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
      if (error < best_error) {
        best_error = error;
        best = int(c);
      }
    }
    if (best < 0) break;
    chosen.push_back(subset[std::size_t(best)]);
    taken[std::size_t(best)] = true;
    for (std::size_t t = 0; t < T; ++t)
      for (int k = 0; k < 3; ++k) {
        const double* row = &Jh[((t * S + std::size_t(best)) * 3 + k) * r];
        for (int i = 0; i < r; ++i) {
          b_base[t * r + i] += row[i] * V[(t * S + std::size_t(best)) * 3 + k];
          for (int j = 0; j < r; ++j) A_base[t * r * r + i * r + j] += row[i] * row[j];
        }
      }
  }
  return chosen;
}

}  // namespace

RomMethod rom_method_from_string(const std::string& name) {
  if (name == "point") return RomMethod::MaterialPoint;
  if (name == "node") return RomMethod::SampleNode;
  throw std::invalid_argument("method must be 'point' (Algorithm 1) or 'node' (Algorithm 2), not '" + name + "'");
}

std::string to_string(RomMethod method) { return method == RomMethod::MaterialPoint ? "point" : "node"; }

SampleSelection sample_selection_from_string(const std::string& name) {
  if (name == "region") return SampleSelection::Region;
  if (name == "random") return SampleSelection::Random;
  if (name == "greedy") return SampleSelection::Greedy;
  throw std::invalid_argument("selection must be 'region', 'random' or 'greedy', not '" + name + "'");
}

std::string to_string(SampleSelection selection) {
  switch (selection) {
    case SampleSelection::Region: return "region";
    case SampleSelection::Random: return "random";
    case SampleSelection::Greedy: return "greedy";
  }
  return "";
}

nlohmann::json RomSettings::to_json() const {
  return {{"method", to_string(method)},
          {"samples", samples},
          {"selection", to_string(selection)},
          {"seed", seed},
          {"cfl", cfl},
          {"envelope_margin", envelope_margin},
          {"quadrature_order", quadrature_order},
          {"newton_tolerance", newton_tolerance},
          {"newton_iterations", newton_iterations},
          {"projection_iterations", projection_iterations},
          {"max_condition", max_condition},
          {"regularization", regularization},
          {"regularize", regularize},
          {"inversion_fallback", inversion_fallback},
          {"max_failed_inversions", max_failed_inversions},
          {"energy_growth", energy_growth},
          {"end_time", end_time}};
}

void RomSettings::validate() const {
  if (samples < 0) throw std::invalid_argument("--samples must be >= 0 (0: all points)");
  // Above 1 lies beyond the explicit FOM's limit; the reduced dynamics (r degrees of freedom) may still be stable.
  if (cfl < 0 || cfl > 10) throw std::invalid_argument("--cfl must be in (0, 10] (0: the scene's)");
  if (!(envelope_margin >= 0) || envelope_margin > 4) throw std::invalid_argument("--margin must be in [0, 4] cells");
  if (quadrature_order < 1 || quadrature_order > 3) throw std::invalid_argument("--quadrature must be 1, 2 or 3");
  if (!(newton_tolerance > 0)) throw std::invalid_argument("--newton-tolerance must be positive");
  if (projection_iterations < 0 || projection_iterations > 10)
    throw std::invalid_argument("--projection-iterations must be in [0, 10]");
  if (newton_iterations < 1) throw std::invalid_argument("--newton-iterations must be >= 1");
  if (max_condition < 0 || regularization < 0)
    throw std::invalid_argument("--max-condition and --regularization must be >= 0");
  if (!(max_failed_inversions >= 0 && max_failed_inversions <= 1))
    throw std::invalid_argument("--max-failed-inversions must be a fraction in [0, 1]");
  if (!(energy_growth >= 0) || !std::isfinite(energy_growth))
    throw std::invalid_argument("--energy-growth must be >= 0 (0: no check)");
  if (!(end_time >= 0) || !std::isfinite(end_time)) throw std::invalid_argument("--end-time must be >= 0 (0: the scene's)");
}

nlohmann::json HyperReduction::summary() const {
  return {{"samples", samples.size()},
          {"source_points", source_points.size()},
          {"neighbours", source_points.empty() ? 0 : source_points.size() - samples.size()},
          {"quadrature_points", quadrature_weight.size()},
          {"nodes", nodes.size()},
          {"node_source_pairs", node_sources.size()}};
}

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
    case SampleSelection::Region:
      return region_samples(model, scene, count);
    case SampleSelection::Random: {
      std::vector<int> order(P);
      std::iota(order.begin(), order.end(), 0);
      std::uint64_t state = settings.seed;
      for (std::size_t i = P - 1; i > 0; --i) std::swap(order[i], order[next_random(state) % (i + 1)]);
      order.resize(count);
      return order;
    }
    case SampleSelection::Greedy:
      if (data != nullptr && !data->train.runs.empty()) return greedy_samples(model, *data, count);
      if (model.sample_ranking.empty())
        throw std::invalid_argument("greedy sample selection: the model stores no sample ranking (it was trained "
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

void impl::apply_horizon(Scene& scene, double end_time) {
  const double interval = scene.end_time / scene.num_outputs;
  const auto name = [] { return std::string("--end-time, in output intervals of the scene,"); };
  scene.num_outputs = impl::checked_integer<int>(std::max(1.0, std::round(end_time / interval)), name, 1);
  scene.end_time = scene.num_outputs * interval;  // a whole number of the scene's output intervals
}

HyperReduction impl::hyper_reduction_from_motion(const Scene& scene, const RomSettings& settings,
                                                 const std::vector<int>& samples,
                                                 const std::vector<double>& positions, std::size_t P,
                                                 const std::vector<int>& next) {
  const GridGeometry<real_t> grid = grid_for_scene(scene);
  const std::size_t C = positions.size() / (3 * P);
  const double margin = settings.envelope_margin;
  const auto position = [&](std::size_t c, std::size_t p) { return &positions[(c * P + p) * 3]; };
  // The nodes point p can reach from configuration c until the next one (its path is a straight line between them).
  const auto reach_from = [&](std::size_t c, std::size_t p, int lo[3], int hi[3]) {
    reach(grid, position(c, p), margin, lo, hi);
    if (next.empty() || next[c] < 0) return;
    int lo2[3], hi2[3];
    reach(grid, position(std::size_t(next[c]), p), margin, lo2, hi2);
    for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], lo2[d]), hi[d] = std::max(hi[d], hi2[d]);
  };
  HyperReduction h;
  h.samples = samples;

  // I: every node a sample's stencil reaches over the training motion.
  std::set<int> node_set;
  for (const int s : samples)
    for (std::size_t c = 0; c < C; ++c) {
      int lo[3], hi[3];
      reach_from(c, std::size_t(s), lo, hi);
      for_each_node(grid, lo, hi, [&](int node) { node_set.insert(node); });
    }
  h.nodes.assign(node_set.begin(), node_set.end());
  std::vector<int> slot(std::size_t(grid.num_nodes()), -1);  // dense: the scans below visit every point at every code
  for (std::size_t n = 0; n < h.nodes.size(); ++n) slot[std::size_t(h.nodes[n])] = int(n);
  std::vector<std::vector<int>> gather(h.nodes.size());

  if (settings.method == RomMethod::MaterialPoint) {
    // Sources: the samples, then their co-moving neighbours N: every point that, at some training code, reaches a
    // node of a sample's stencil at that same code (a point passing through where a sample was at another time
    // never shares its nodes). Node n gathers from p if p reaches n while n is in a sample's stencil; at run time the
    // nodes around the samples are then complete, and the other nodes of I, incomplete, are never read by G2P.
    const std::size_t S = samples.size();
    struct Box {
      int lo[3], hi[3];
    };
    std::vector<Box> sample_box(C * S), union_box(C);
    for (std::size_t c = 0; c < C; ++c) {
      Box& u = union_box[c];
      for (int d = 0; d < 3; ++d) u.lo[d] = grid.dims[d], u.hi[d] = -1;
      for (std::size_t k = 0; k < S; ++k) {
        Box& b = sample_box[c * S + k];
        reach_from(c, std::size_t(samples[k]), b.lo, b.hi);
        for (int d = 0; d < 3; ++d) u.lo[d] = std::min(u.lo[d], b.lo[d]), u.hi[d] = std::max(u.hi[d], b.hi[d]);
      }
    }
    const auto intersect = [](const Box& a, const Box& b, Box& out) {
      for (int d = 0; d < 3; ++d) {
        out.lo[d] = std::max(a.lo[d], b.lo[d]);
        out.hi[d] = std::min(a.hi[d], b.hi[d]);
        if (out.lo[d] > out.hi[d]) return false;
      }
      return true;
    };
    std::vector<int> source_of(P, -1);
    for (const int k : samples) {
      source_of[k] = int(h.source_points.size());
      h.source_points.push_back(k);
    }
    std::vector<int> reached;
    for (std::size_t p = 0; p < P; ++p) {
      reached.clear();
      for (std::size_t c = 0; c < C; ++c) {
        Box own, shared;
        reach_from(c, p, own.lo, own.hi);
        if (!intersect(own, union_box[c], shared)) continue;
        for (std::size_t k = 0; k < S; ++k) {
          if (!intersect(own, sample_box[c * S + k], shared)) continue;
          for_each_node(grid, shared.lo, shared.hi, [&](int node) {
            const int n = slot[std::size_t(node)];
            if (std::find(reached.begin(), reached.end(), n) == reached.end()) reached.push_back(n);
          });
        }
      }
      if (reached.empty()) continue;
      if (source_of[p] < 0) {
        source_of[p] = int(h.source_points.size());
        h.source_points.push_back(int(p));
      }
      for (const int n : reached) gather[std::size_t(n)].push_back(source_of[p]);
    }
  } else {
    // Quadrature: Gauss points of the dual cells (the node-centred cells on which the B-splines are polynomial)
    // around every node of I that the training motion brings material near.
    std::vector<char> occupied(std::size_t(grid.num_nodes()), 0);
    for (std::size_t c = 0; c < C; ++c)
      for (std::size_t p = 0; p < P; ++p) {
        int lo[3], hi[3];
        reach(grid, position(c, p), margin, lo, hi);
        // the dual cell holding the point is the middle node of its stencil
        occupied[std::size_t(grid.index((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2))] = 1;
      }
    std::set<int> cells;
    for (const int node : h.nodes) {
      int idx[3];
      grid.indices(node, idx[0], idx[1], idx[2]);
      for (int a = -1; a <= 1; ++a)
        for (int b = -1; b <= 1; ++b)
          for (int d = -1; d <= 1; ++d) {
            const int i = idx[0] + a, j = idx[1] + b, k = idx[2] + d;
            if (i < 0 || j < 0 || k < 0 || i >= grid.dims[0] || j >= grid.dims[1] || k >= grid.dims[2]) continue;
            // keep cells next to material somewhere in the training motion
            bool near = false;
            for (int e = -1; e <= 1 && !near; ++e)
              for (int f = -1; f <= 1 && !near; ++f)
                for (int g = -1; g <= 1 && !near; ++g) {
                  const int ii = i + e, jj = j + f, kk = k + g;
                  if (ii < 0 || jj < 0 || kk < 0 || ii >= grid.dims[0] || jj >= grid.dims[1] || kk >= grid.dims[2])
                    continue;
                  near = occupied[std::size_t(grid.index(ii, jj, kk))] != 0;
                }
            if (near) cells.insert(grid.index(i, j, k));
          }
    }
    static const double gauss_points[3][3] = {{0, 0, 0}, {-0.5773502691896257, 0.5773502691896257, 0},
                                              {-0.7745966692414834, 0, 0.7745966692414834}};
    static const double gauss_weights[3][3] = {{2, 0, 0}, {1, 1, 0}, {5.0 / 9, 8.0 / 9, 5.0 / 9}};
    const int order = settings.quadrature_order;
    const double half = 0.5 * grid.dx;
    std::unordered_map<int, int> first_point;
    for (const int cell : cells) {
      int idx[3];
      grid.indices(cell, idx[0], idx[1], idx[2]);
      const Vec3<real_t> center = grid.position(idx[0], idx[1], idx[2]);
      first_point[cell] = int(h.quadrature_weight.size());
      for (int a = 0; a < order; ++a)
        for (int b = 0; b < order; ++b)
          for (int d = 0; d < order; ++d) {
            h.quadrature_x.push_back(center[0] + half * gauss_points[order - 1][a]);
            h.quadrature_x.push_back(center[1] + half * gauss_points[order - 1][b]);
            h.quadrature_x.push_back(center[2] + half * gauss_points[order - 1][d]);
            h.quadrature_weight.push_back(half * half * half * gauss_weights[order - 1][a] *
                                          gauss_weights[order - 1][b] * gauss_weights[order - 1][d]);
          }
    }
    const int per_cell = order * order * order;
    for (std::size_t n = 0; n < h.nodes.size(); ++n) {
      int idx[3];
      grid.indices(h.nodes[n], idx[0], idx[1], idx[2]);
      for (int a = -1; a <= 1; ++a)
        for (int b = -1; b <= 1; ++b)
          for (int d = -1; d <= 1; ++d) {
            const int i = idx[0] + a, j = idx[1] + b, k = idx[2] + d;
            if (i < 0 || j < 0 || k < 0 || i >= grid.dims[0] || j >= grid.dims[1] || k >= grid.dims[2]) continue;
            const auto it = first_point.find(grid.index(i, j, k));
            if (it == first_point.end()) continue;
            for (int q = 0; q < per_cell; ++q) gather[n].push_back(it->second + q);
          }
    }
  }
  h.node_offsets.push_back(0);
  for (auto& list : gather) {
    std::sort(list.begin(), list.end());
    h.node_sources.insert(h.node_sources.end(), list.begin(), list.end());
    h.node_offsets.push_back(int(h.node_sources.size()));
  }
  return h;
}

HyperReduction build_hyper_reduction(const Model& model, const Scene& scene, const RomSettings& settings,
                                     const std::vector<int>& samples) {
  // Each training code's successor in time within its run.
  std::map<std::int64_t, std::vector<int>> run_codes;
  for (std::size_t c = 0; c < model.num_codes(); ++c) run_codes[model.code_run[c]].push_back(int(c));
  std::vector<int> next(model.num_codes(), -1);
  for (auto& [run, codes] : run_codes) {
    std::sort(codes.begin(), codes.end(), [&](int a, int b) { return model.code_time[a] < model.code_time[b]; });
    for (std::size_t k = 0; k + 1 < codes.size(); ++k) next[std::size_t(codes[k])] = codes[k + 1];
  }
  return impl::hyper_reduction_from_motion(scene, settings, samples, training_positions(model), model.num_points(),
                                           next);
}

namespace {

// The scene's material points must be the model's reference points: a model trained on another scene (or another
// resolution) cannot be rolled out on this one.
void check_model_fits_scene(const Model& model, const Scene& scene, const ParticleSamples& samples) {
  if (samples.size() != model.num_points())
    throw std::runtime_error("the model was trained on " + std::to_string(model.num_points()) +
                             " material points (scene '" + model.scene_name + "'); scene '" + scene.name + "' has " +
                             std::to_string(samples.size()));
  for (std::size_t i = 0; i < samples.X.size(); ++i)
    if (std::fabs(samples.X[i] - model.X[i]) > 1e-6 * std::max(1.0, std::fabs(model.X[i])))
      throw std::runtime_error("the scene's material point " + std::to_string(i / 3) +
                               " is not where the model's was; the model was trained on scene '" + model.scene_name +
                               "'");
}

// xhat(0): Levenberg-Marquardt on the positions; xhatdot(0): least squares on the velocities, over every point.
void initial_state(const Model& model, const ParticleSamples& samples, const Scene& scene, std::vector<double>& xhat,
                   std::vector<double>& xhatdot) {
  const int r = model.latent_dim;
  const std::size_t P = model.num_points();
  Snapshot start;
  start.num_points = P;
  start.num_frames = 1;
  start.X = model.X;
  start.x = model.X;
  start.time = {0.0};
  xhat = project_codes(model, start);
  xhatdot.assign(r, 0.0);
  std::vector<double> v(3 * P);
  bool moving = false;
  for (std::size_t p = 0; p < P; ++p) {
    const BodySpec& body = scene.bodies[samples.body[p]];
    const double* X = &samples.X[3 * p];
    const double arm[3] = {X[0] - body.center[0], X[1] - body.center[1], X[2] - body.center[2]};
    const auto& w = body.angular_velocity;
    const double spin[3] = {w[1] * arm[2] - w[2] * arm[1], w[2] * arm[0] - w[0] * arm[2], w[0] * arm[1] - w[1] * arm[0]};
    for (int d = 0; d < 3; ++d) {
      v[3 * p + d] = samples.velocity[3 * p + d];
      moving = moving || v[3 * p + d] != 0.0 || spin[d] != 0.0;
    }
  }
  if (!moving) return;
  const Vector params = upload<Vector>("mpmrom::rom::params", model.weights, model.layout().num_params);
  Cube g("g", 1, P, 3), no_velocity;
  Quad F("F", 1, P, 3, 3), J("J", 1, P, 3, r);
  nn::evaluate_with_jacobians(ExecutionSpace(), impl::device_mlp(model, params),
                              nn::PointsView<real_t, MemorySpace>(upload<Matrix>("X", model.X, P, 3)),
                              nn::CodesView<real_t, MemorySpace>(upload<Matrix>("xhat", xhat, 1, r)),
                              nn::CodesView<real_t, MemorySpace>(), g, F, J, no_velocity);
  const auto Jh = download(J);
  std::vector<double> A(r * r, 0.0), b(r, 0.0);
  for (std::size_t row = 0; row < 3 * P; ++row)
    for (int i = 0; i < r; ++i) {
      b[i] += Jh[row * r + i] * v[row];
      for (int j = 0; j < r; ++j) A[i * r + j] += Jh[row * r + i] * Jh[row * r + j];
    }
  if (!dense::SerialCholesky(A.data(), r, r))
    throw std::runtime_error("the initial velocity cannot be projected: dg/dxhat is rank-deficient at xhat(0)");
  dense::SerialCholeskySolve(A.data(), r, r, b.data());
  xhatdot = b;
}

}  // namespace

rom::RolloutLoads impl::loads_for_scene(const Scene& scene, const ReferencePoints& model) {
  rom::RolloutLoads loads;
  if (scene.forces.size() > std::size_t(kMaxExternalForces))
    throw std::runtime_error("at most " + std::to_string(kMaxExternalForces) + " [[force]] entries are supported");
  if (scene.dirichlet.size() > std::size_t(kMaxDirichletRegions))
    throw std::runtime_error("at most " + std::to_string(kMaxDirichletRegions) + " [[dirichlet]] entries are supported");
  for (const auto& f : scene.forces) {
    double region_mass = 0;
    for (std::size_t p = 0; p < model.mass.size(); ++p)
      if (f.region.contains({model.X[3 * p], model.X[3 * p + 1], model.X[3 * p + 2]})) region_mass += model.mass[p];
    if (!(region_mass > 0)) throw std::runtime_error("a [[force]] region holds none of the model's material points");
    const int k = loads.num_forces++;
    for (int d = 0; d < 3; ++d) {
      loads.force_per_mass[3 * k + d] = real_t(f.force[d] / region_mass);
      loads.force_box[6 * k + d] = real_t(f.region.lo[d]);
      loads.force_box[6 * k + 3 + d] = real_t(f.region.hi[d]);
    }
    loads.force_window[2 * k] = real_t(f.start);
    loads.force_window[2 * k + 1] = real_t(std::min(f.end, 1e30));
  }
  GridBoundary& boundary = loads.boundary;
  boundary.walls = to_contact(scene.walls);
  boundary.ground = scene.ground.enabled;
  boundary.ground_height = real_t(scene.ground.height);
  boundary.ground_contact = to_contact(scene.ground.contact);
  for (const auto& region : scene.dirichlet) {
    const int r = boundary.num_dirichlet++;
    for (int d = 0; d < 3; ++d) {
      boundary.dirichlet_box[6 * r + d] = real_t(region.region.lo[d]);
      boundary.dirichlet_box[6 * r + 3 + d] = real_t(region.region.hi[d]);
      boundary.dirichlet_velocity[3 * r + d] = real_t(region.velocity[d]);
    }
    loads.dirichlet_window[2 * r] = real_t(region.start);
    loads.dirichlet_window[2 * r + 1] = real_t(std::min(region.end, 1e30));
  }
  for (int d = 0; d < 3; ++d) loads.gravity[d] = real_t(scene.gravity[d]);
  return loads;
}

rom::ReferenceDomain impl::reference_domain(const Scene& scene) {
  rom::ReferenceDomain domain;
  if (scene.bodies.size() > std::size_t(rom::max_reference_bodies))
    throw std::runtime_error("the sample-node ROM supports at most " + std::to_string(rom::max_reference_bodies) +
                             " bodies");
  for (const auto& body : scene.bodies) {
    const int b = domain.num_bodies++;
    domain.shape[b] = body.shape == ShapeKind::Box        ? rom::ReferenceDomain::Box
                      : body.shape == ShapeKind::Cylinder ? rom::ReferenceDomain::Cylinder
                                                          : rom::ReferenceDomain::Sphere;
    for (int d = 0; d < 3; ++d) {
      domain.center[3 * b + d] = real_t(body.center[d]);
      domain.half_extents[3 * b + d] = real_t(body.half_extents[d]);
    }
    domain.radius[b] = real_t(body.radius);
    domain.half_height[b] = real_t(body.height / 2);
  }
  return domain;
}

std::string impl::describe_flags(int flags, bool with_remedies) {
  struct Cause {
    int flag;
    const char *what, *remedy;
  };
  static constexpr Cause table[] = {
      {rom::flag_inverted, "an inverted deformation gradient (det F <= 0)", "try a smaller --cfl or more --samples"},
      {rom::flag_not_finite, "a non-finite projected velocity", "try a smaller --cfl"},
      {rom::flag_left_node_set,
       "a sample point left the precomputed node set (motion beyond the training envelope)",
       "widen --margin, or train on runs whose motion covers these parameters"},
      {rom::flag_singular, "singular normal equations even after regularisation",
       "use more --samples or --selection greedy"},
      {rom::flag_ill_posed,
       "ill-conditioned normal equations (condition estimate above the limit, regularisation off)",
       "drop --no-regularize or use more --samples"},
      {rom::flag_energy,
       "energy blow-up: the latent speed exceeded --energy-growth times the fastest training motion",
       "try more --samples or a smaller --cfl, or raise --energy-growth if the motion is truly faster"},
      {rom::flag_inversion,
       "Newton's inversion failed at more than --max-failed-inversions of the quadrature points",
       "try --method point, or raise --newton-iterations"},
  };
  std::vector<std::string> causes;
  for (const Cause& c : table)
    if (flags & c.flag) causes.push_back(std::string(c.what) + (with_remedies ? std::string(" (") + c.remedy + ")" : ""));
  std::string out;
  for (std::size_t i = 0; i < causes.size(); ++i) out += (i ? "; " : "") + causes[i];
  return out;
}

namespace {

// The checkpoint a rollout resumes from: the one at path; under MPI, the latest frame every rank saved (a rank
// killed while the ranks wrote a new one still has the one before at path.prev). False: start from the beginning.
bool resume_from_checkpoint(impl::BatchStepperBase& stepper, RomResult& result, const std::string& path,
                            const std::string& identity, const parallel::Communicator& comm) {
  impl::BatchState saved;
  const auto frame_of = [&](const std::string& file) {
    saved = impl::BatchState();
    return impl::load_rollout_checkpoint(file, identity, saved, result) ? saved.frame : 0;
  };
  const std::string previous = path + ".prev";
  int frame = frame_of(path);
  if (comm.size() > 1) {
    if (frame == 0) frame = frame_of(previous);
    const int common = int(comm.min(frame));
    if (frame != common && frame_of(previous) != common)
      throw std::runtime_error(path + ": the ranks' checkpoints are of different frames (" + std::to_string(frame) +
                               " here, " + std::to_string(common) + " on another rank)");
    frame = common;
  }
  if (frame == 0) return false;
  try {
    stepper.restore(saved);
  } catch (const std::exception& error) {
    throw std::runtime_error(path + ": " + error.what());
  }
  return true;
}

// Under MPI the ranks write their checkpoints together; until all have the new one, each keeps its last one.
void save_checkpoint(const impl::BatchStepperBase& stepper, const RomResult& result, const std::string& path,
                     const std::string& identity, const parallel::Communicator& comm) {
  std::error_code ignored;
  const std::string previous = path + ".prev";
  if (comm.size() > 1) std::filesystem::rename(path, previous, ignored);
  impl::save_rollout_checkpoint(path, identity, stepper.state(), result);
  if (comm.size() > 1) {
    comm.barrier();
    std::filesystem::remove(previous, ignored);
  }
}

}  // namespace

void impl::record_rollouts(BatchStepperBase& stepper, RomResult& result,
                           const std::function<void(const RomProgress&)>& progress,
                           const RolloutCheckpoint& checkpoint, const std::string& identity,
                           const parallel::Communicator& comm) {
  const std::size_t B = std::size_t(stepper.rollouts()), frames = std::size_t(stepper.frames());
  const std::size_t r = std::size_t(stepper.latent_dim());
  result.times = stepper.times();
  result.xhat.assign(B * frames * r, 0.0);
  result.xhatdot.assign(B * frames * r, 0.0);
  std::vector<double> xhat, xhatdot;
  const auto record = [&]() {
    stepper.latent(xhat, xhatdot);  // a stopped rollout keeps its last good state
    const std::size_t frame = std::size_t(stepper.frame());
    for (std::size_t b = 0; b < B; ++b)
      for (std::size_t q = 0; q < r; ++q) {
        result.xhat[(b * frames + frame) * r + q] = xhat[b * r + q];
        result.xhatdot[(b * frames + frame) * r + q] = xhatdot[b * r + q];
      }
  };
  if (comm.size() > 1)
    stepper.share_time_step([&comm](double* values, std::size_t count) { comm.max(values, count); });
  const bool checkpointing = !checkpoint.path.empty();
  if (!(checkpointing && checkpoint.resume && resume_from_checkpoint(stepper, result, checkpoint.path, identity, comm)))
    record();
  auto last_checkpoint = Clock::now();
  while (stepper.advance_frame()) {
    record();
    if (progress)
      progress({stepper.frame(), int(frames) - 1, stepper.time(), stepper.steps(), stepper.step_seconds()});
    // every rank asks, so that all checkpoint at the same frame
    if (checkpointing && stepper.frame() + 1 < int(frames) &&
        comm.any(seconds_since(last_checkpoint) >= checkpoint.seconds)) {
      save_checkpoint(stepper, result, checkpoint.path, identity, comm);
      last_checkpoint = Clock::now();
    }
  }
  stepper.share_time_step({});
  result.steps = stepper.steps();
  result.step_seconds = stepper.step_seconds();
  result.outcomes = stepper.outcomes();
}

double training_latent_speed(const Model& model) {
  const int r = model.latent_dim;
  std::map<std::int64_t, std::vector<int>> run_codes;
  for (std::size_t c = 0; c < model.num_codes(); ++c) run_codes[model.code_run[c]].push_back(int(c));
  double fastest = 0;
  for (auto& [run, codes] : run_codes) {
    std::sort(codes.begin(), codes.end(), [&](int a, int b) { return model.code_time[a] < model.code_time[b]; });
    for (std::size_t k = 0; k + 1 < codes.size(); ++k) {
      const double dt = model.code_time[codes[k + 1]] - model.code_time[codes[k]];
      if (!(dt > 0)) continue;
      double step2 = 0;
      for (int q = 0; q < r; ++q) {
        const double d = model.codes[std::size_t(codes[k + 1]) * r + q] - model.codes[std::size_t(codes[k]) * r + q];
        step2 += d * d;
      }
      fastest = std::max(fastest, std::sqrt(step2) / dt);
    }
  }
  return fastest;
}

std::vector<std::string> training_range_warnings(const Model& model, const std::vector<std::string>& names,
                                                 const std::vector<RolloutCase>& cases) {
  std::vector<std::string> warnings(cases.size());
  if (model.scene_text.empty()) return warnings;
  Scene trained;
  try {
    trained = parse_scene(model.scene_text, "the model's scene");
  } catch (const std::exception&) {
    return warnings;  // a model from another version of the scene format: no range to compare with
  }
  const ParameterDesign& design = trained.design;
  const auto runs = design.all_runs();
  // the training runs' range of each named parameter (lo > hi: not a parameter of the design)
  std::vector<double> lo(names.size(), std::numeric_limits<double>::infinity()), hi(names.size(), -lo[0]);
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto it = std::find(design.names.begin(), design.names.end(), names[i]);
    if (it == design.names.end()) continue;
    const std::size_t column = std::size_t(it - design.names.begin());
    for (std::size_t run = 0; run < runs.size(); ++run) {
      if (std::find(design.test_runs.begin(), design.test_runs.end(), int(run)) != design.test_runs.end()) continue;
      lo[i] = std::min(lo[i], runs[run][column]);
      hi[i] = std::max(hi[i], runs[run][column]);
    }
  }
  for (std::size_t c = 0; c < cases.size(); ++c) {
    const std::vector<double>& values = cases[c].values;
    std::string warning;
    for (std::size_t i = 0; i < names.size() && i < values.size(); ++i) {
      if (!(lo[i] <= hi[i]) || (values[i] >= lo[i] && values[i] <= hi[i])) continue;
      const double beyond = values[i] < lo[i] ? lo[i] - values[i] : values[i] - hi[i];
      std::ostringstream line;
      line << (warning.empty() ? "" : "; ") << names[i] << " = " << values[i] << " lies outside the training range ["
           << lo[i] << ", " << hi[i] << "]";
      if (hi[i] > lo[i]) line << " by " << std::lround(100 * beyond / (hi[i] - lo[i])) << " % of its width";
      warning += line.str();
    }
    warnings[c] = warning.empty() ? warning : warning + " (extrapolation: expect larger errors)";
  }
  return warnings;
}

std::string training_range_warning(const Model& model, const std::vector<std::string>& names,
                                   const std::vector<double>& values) {
  return training_range_warnings(model, names, {RolloutCase{values, ""}}).front();
}

namespace {

// FNV-1a over what makes a batch: the network's weights, the scene file, the settings and every rollout's values.
std::string batch_identity(const Model& model, const std::string& scene_path, const std::vector<std::string>& names,
                           const std::vector<RolloutCase>& cases, const RomSettings& settings) {
  std::uint64_t hash = 1469598103934665603ULL;
  const auto add = [&](const void* data, std::size_t bytes) {
    const auto* byte = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) hash = (hash ^ byte[i]) * 1099511628211ULL;
  };
  add(model.weights.data(), model.weights.size() * sizeof(double));
  std::ifstream scene(scene_path, std::ios::binary);
  const std::string scene_text((std::istreambuf_iterator<char>(scene)), std::istreambuf_iterator<char>());
  const std::string text = scene_text + settings.to_json().dump();
  add(text.data(), text.size());
  for (const auto& name : names) add(name.data(), name.size() + 1);
  for (const auto& c : cases) add(c.values.data(), c.values.size() * sizeof(double));
  return std::to_string(hash);
}

}  // namespace

std::unique_ptr<impl::BatchStepperBase> impl::create_stepper(const Model& model, const std::string& scene_path,
                                                            const std::vector<std::string>& names,
                                                            const std::vector<RolloutCase>& cases,
                                                            const RomSettings& settings,
                                                            const HyperReduction& reduction) {
  settings.validate();
  if (model.latent_dim > rom::max_latent_dim)
    throw std::runtime_error("the reduced model supports latent dimensions up to " +
                             std::to_string(rom::max_latent_dim) + "; the model has " +
                             std::to_string(model.latent_dim));
  if (cases.empty()) throw std::runtime_error("no rollouts to run: the parameter list is empty");
  if (reduction.samples.empty() || reduction.nodes.empty())
    throw std::runtime_error("the hyper-reduction has no sample points or no nodes");
  std::vector<rom::RolloutLoads> loads;
  std::vector<double> xhat0, xhatdot0;
  const SceneRuns scene_runs(scene_path);
  Scene first;
  std::vector<double> first_xhat, first_xhatdot;
  for (std::size_t c = 0; c < cases.size(); ++c) {
    if (cases[c].values.size() != names.size())
      throw std::runtime_error("rollout " + std::to_string(c) + " has " + std::to_string(cases[c].values.size()) +
                               " parameter values for " + std::to_string(names.size()) + " names");
    const Scene scene = scene_runs.run(names, cases[c].values);
    if (c == 0) {
      first = scene;
      const ParticleSamples samples = sample_scene(scene);
      check_model_fits_scene(model, scene, samples);
      initial_state(model, samples, scene, first_xhat, first_xhatdot);
    } else {
      // One batch shares the grid, the material and the output times; its rollouts differ in loads only.
      const bool same = scene.dx == first.dx && scene.material.youngs_modulus == first.material.youngs_modulus &&
                        scene.material.poisson_ratio == first.material.poisson_ratio &&
                        scene.material.density == first.material.density && scene.end_time == first.end_time &&
                        scene.num_outputs == first.num_outputs && scene.domain.lo == first.domain.lo &&
                        scene.domain.hi == first.domain.hi;
      if (!same)
        throw std::runtime_error("rollout " + std::to_string(c) +
                                 ": its parameters change the grid, material or output times; a batch may vary loads "
                                 "and boundary values only");
      bool same_motion = scene.bodies.size() == first.bodies.size();
      for (std::size_t k = 0; same_motion && k < scene.bodies.size(); ++k)
        same_motion = scene.bodies[k].velocity == first.bodies[k].velocity &&
                      scene.bodies[k].angular_velocity == first.bodies[k].angular_velocity;
      if (!same_motion)
        throw std::runtime_error("rollout " + std::to_string(c) +
                                 ": its parameters change the initial velocity; run it in a batch of its own");
    }
    loads.push_back(impl::loads_for_scene(scene, {model.X, model.mass, model.volume}));
    xhat0.insert(xhat0.end(), first_xhat.begin(), first_xhat.end());
    xhatdot0.insert(xhatdot0.end(), first_xhatdot.begin(), first_xhatdot.end());
  }
  if (settings.end_time > 0) impl::apply_horizon(first, settings.end_time);
  const double max_latent_speed = settings.energy_growth * training_latent_speed(model);
  const Vector params = upload<Vector>("mpmrom::rom::params", model.weights, model.layout().num_params);
  nn::TeamMlp<real_t, MemorySpace> team;
  team.layout = model.layout();
  team.arranged = nn::TeamMlpLayout::make(team.layout);
  team.standardization = impl::device_mlp(model, params).standardization;
  const std::vector<double> arranged = nn::arrange_for_teams<double>(team.layout, team.arranged, model.weights);
  team.values = upload<Vector>("mpmrom::rom::team_params", arranged, arranged.size());
  // GPUs read the weights from shared memory when they take at most half of a team's scratch; host caches need no copy
  const bool stage = !Kokkos::SpaceAccessibility<Kokkos::HostSpace, MemorySpace>::accessible &&
                     arranged.size() * sizeof(real_t) <= rom::team_scratch_budget / 2;
  std::unique_ptr<impl::BatchStepperBase> stepper;
  nn::dispatch_max_width(model.layout().widest, [&](auto width) {
    using Manifold = rom::MlpManifold<decltype(width)::value, MemorySpace>;
    stepper = std::make_unique<impl::BatchStepper<Manifold>>(
        Manifold{impl::device_mlp(model, params), team, stage}, model.latent_dim,
        impl::ReferencePoints{model.X, model.mass, model.volume},
        first, loads, xhat0, xhatdot0, settings, max_latent_speed, reduction);
  });
  return stepper;
}

RomResult run_rollouts(const Model& model, const std::string& scene_path, const std::vector<std::string>& names,
                       const std::vector<RolloutCase>& cases, const RomSettings& settings,
                       const HyperReduction& reduction, const std::function<void(const RomProgress&)>& progress,
                       const RolloutCheckpoint& checkpoint) {
  const auto start = Clock::now();
  RomResult result;
  result.parameter_names = names;
  result.cases = cases;
  result.latent_dim = model.latent_dim;
  const auto stepper = impl::create_stepper(model, scene_path, names, cases, settings, reduction);
  result.setup_seconds = seconds_since(start);
  impl::record_rollouts(*stepper, result, progress, checkpoint,
                        checkpoint.path.empty() ? "" : batch_identity(model, scene_path, names, cases, settings));
  const auto warnings = training_range_warnings(model, names, cases);
  for (std::size_t c = 0; c < cases.size(); ++c) result.outcomes[c].warning = warnings[c];
  return result;
}

namespace {

// A rank's share of a batch's result, as bytes for the gather to rank 0: trajectories and outcomes.
class ShareWriter {
 public:
  template <class T>
  void value(const T& v) {
    bytes_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void doubles(const std::vector<double>& v) {
    value(std::uint64_t(v.size()));
    bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
  }
  void text(const std::string& t) {
    value(std::uint64_t(t.size()));
    bytes_ += t;
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

class ShareReader {
 public:
  explicit ShareReader(const std::string& bytes) : bytes_(bytes) {}
  template <class T>
  T value() {
    T v;
    take(&v, sizeof(T));
    return v;
  }
  void append_doubles(std::vector<double>& out) {
    const auto n = std::size_t(value<std::uint64_t>());
    const std::size_t old = out.size();
    out.resize(old + n);
    take(out.data() + old, n * sizeof(double));
  }
  std::string text() {
    std::string t(std::size_t(value<std::uint64_t>()), '\0');
    take(t.data(), t.size());
    return t;
  }

 private:
  void take(void* to, std::size_t n) {
    if (n > bytes_.size() - at_) throw std::runtime_error("MPI: a rank's rollout results arrived incomplete");
    std::memcpy(to, bytes_.data() + at_, n);
    at_ += n;
  }
  const std::string& bytes_;
  std::size_t at_ = 0;
};

std::string share_bytes(const RomResult& share) {
  ShareWriter w;
  w.doubles(share.xhat);
  w.doubles(share.xhatdot);
  w.value(std::uint64_t(share.outcomes.size()));
  for (const auto& o : share.outcomes) {
    w.value(o.flags);
    w.value(o.frames_completed);
    w.value(o.stopped_at);
    w.value(o.max_condition);
    w.value(o.regularized_steps);
    w.value(o.inversion_failures);
    w.value(o.inversion_fallbacks);
    w.text(o.message);
    w.text(o.warning);
  }
  return w.bytes();
}

void append_share(RomResult& whole, const std::string& bytes) {
  ShareReader in(bytes);
  in.append_doubles(whole.xhat);
  in.append_doubles(whole.xhatdot);
  const auto count = std::size_t(in.value<std::uint64_t>());
  for (std::size_t b = 0; b < count; ++b) {
    RolloutOutcome o;
    o.flags = in.value<int>();
    o.frames_completed = in.value<int>();
    o.stopped_at = in.value<double>();
    o.max_condition = in.value<double>();
    o.regularized_steps = in.value<long>();
    o.inversion_failures = in.value<long>();
    o.inversion_fallbacks = in.value<long>();
    o.message = in.text();
    o.warning = in.text();
    whole.outcomes.push_back(std::move(o));
  }
}

}  // namespace

std::string rank_checkpoint_path(const std::string& path, int rank, int size) {
  return size > 1 ? path + ".rank" + std::to_string(rank) : path;
}

RomResult run_rollouts(const parallel::Communicator& comm, const Model& model, const std::string& scene_path,
                       const std::vector<std::string>& names, const std::vector<RolloutCase>& cases,
                       const RomSettings& settings, const HyperReduction& reduction,
                       const std::function<void(const RomProgress&)>& progress,
                       const RolloutCheckpoint& checkpoint) {
  if (comm.size() == 1) return run_rollouts(model, scene_path, names, cases, settings, reduction, progress, checkpoint);
  if (cases.size() < std::size_t(comm.size()))
    throw std::runtime_error(std::to_string(cases.size()) + " rollout(s) cannot be shared by " +
                             std::to_string(comm.size()) + " processes: run with at most one process per rollout");
  const auto start = Clock::now();
  const auto share = parallel::share_of(cases.size(), comm.rank(), comm.size());
  const std::vector<RolloutCase> mine(cases.begin() + long(share.begin), cases.begin() + long(share.end));
  RomResult result;
  result.parameter_names = names;
  result.cases = mine;
  result.latent_dim = model.latent_dim;
  const auto stepper = impl::create_stepper(model, scene_path, names, mine, settings, reduction);
  result.setup_seconds = comm.max(seconds_since(start));
  RolloutCheckpoint own = checkpoint;
  own.path = checkpoint.path.empty() ? "" : rank_checkpoint_path(checkpoint.path, comm.rank(), comm.size());
  impl::record_rollouts(*stepper, result, comm.is_root() ? progress : std::function<void(const RomProgress&)>(), own,
                        own.path.empty() ? "" : batch_identity(model, scene_path, names, mine, settings), comm);
  const auto warnings = training_range_warnings(model, names, mine);
  for (std::size_t c = 0; c < mine.size(); ++c) result.outcomes[c].warning = warnings[c];
  result.step_seconds = comm.max(result.step_seconds);  // the ranks step together: the slowest one's time
  const auto parts = comm.gather(share_bytes(result));
  if (!comm.is_root()) return result;
  RomResult whole = result;
  whole.cases = cases;
  whole.xhat.clear();
  whole.xhatdot.clear();
  whole.outcomes.clear();
  for (const auto& part : parts) append_share(whole, part);
  return whole;
}

DecodedFields decode(const Model& model, const std::vector<double>& X, const std::vector<double>& codes,
                     const std::vector<double>& rates) {
  const int r = model.latent_dim;
  const std::size_t P = X.size() / 3, frames = codes.size() / r;
  const Vector params = upload<Vector>("mpmrom::rom::params", model.weights, model.layout().num_params);
  Cube g("mpmrom::rom::decode_x", frames, P, 3), v("mpmrom::rom::decode_v", frames, P, 3);
  Quad F("mpmrom::rom::decode_F", frames, P, 3, 3), J("mpmrom::rom::decode_J", frames, P, 3, r);
  nn::evaluate_with_jacobians(ExecutionSpace(), impl::device_mlp(model, params),
                              nn::PointsView<real_t, MemorySpace>(upload<Matrix>("X", X, P, 3)),
                              nn::CodesView<real_t, MemorySpace>(upload<Matrix>("codes", codes, frames, r)),
                              nn::CodesView<real_t, MemorySpace>(upload<Matrix>("rates", rates, frames, r)), g, F, J,
                              v);
  return {download(g), download(v), download(F)};
}

}  // namespace mpmrom
