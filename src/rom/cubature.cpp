// Empirical cubature of the samples' projection (ECSW, Farhat et al.): non-negative weights with which the samples'
// sums reproduce the all-point, mass-weighted sums of the projection over snapshots, and the greedy choice of the
// samples that Lawson and Hanson's active set makes (docs/rom.md "Sample weights"). Snapshots come from the
// full-order training runs, or from the all-point reduced model's own projections.
#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "core/math/nnls.hpp"
#include "mpmrom/rom.hpp"
#include "rom/detail/decoder.hpp"
#include "rom/detail/rom_stepper.hpp"
#include "rom/detail/training_frames.hpp"

namespace mpmrom {
namespace {

// One snapshot at every point: dg/dxhat (P, 3, r), the fields whose projections J^T (field) the samples must
// reproduce (each (P, 3)) and, for the Galerkin step, each point's reduced force per unit mass (P, r; null: none).
struct PointSnapshot {
  const double* J;
  std::vector<const double*> fields;
  const double* reduced = nullptr;
  std::size_t blocks() const { return fields.size() + (reduced != nullptr ? 1 : 0); }
};
using SnapshotStream = std::function<void(const std::function<void(const PointSnapshot&)>&)>;

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
    q.resize(Q);
    const std::size_t first = system.f.size();
    system.f.resize(first + Q, 0.0);
    system.E.resize((first + Q) * C, 0.0);
    for (std::size_t p = 0; p < P; ++p) {
      point_quantities(snapshot, p, r, q.data());
      for (std::size_t k = 0; k < Q; ++k) system.f[first + k] += model.mass[p] * q[k];
    }
    for (std::size_t c = 0; c < C; ++c) {
      point_quantities(snapshot, std::size_t(candidates[c]), r, q.data());
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

// Every point, or 2048 spread evenly over a larger body (the normal form is candidates squared).
std::vector<int> all_candidates(const Model& model) {
  const std::size_t P = model.num_points(), stride = std::max<std::size_t>(1, (P + 2047) / 2048);
  std::vector<int> candidates;
  for (std::size_t p = 0; p < P; p += stride) candidates.push_back(int(p));
  return candidates;
}

// J at about `snapshots` codes of the training runs, with the runs' velocities and accelerations there.
SnapshotStream training_runs(const Model& model, const TrainingData& data, std::size_t snapshots) {
  return [&model, &data, snapshots](const std::function<void(const PointSnapshot&)>& use) {
    const int r = model.latent_dim;
    const std::size_t P = model.num_points();
    for (const auto& frame : impl::training_frames(model, data, snapshots)) {
      const std::vector<double> code(model.codes.begin() + std::ptrdiff_t(frame.code * r),
                                     model.codes.begin() + std::ptrdiff_t((frame.code + 1) * r));
      const std::vector<double> J = impl::decoder_jacobians(model, model.X, code);  // one snapshot at a time
      const Snapshot& run = data.train.runs[frame.run];
      const std::vector<double> a = impl::frame_accelerations(run, frame.frame);
      use({J.data(), {&run.v[frame.frame * P * 3], a.data()}});
    }
  };
}

// The all-point reduced model over at most max_rollouts of the scene's training design: at every output frame, J
// of its last sub-step's final pass and the velocity that sub-step added.
SnapshotStream reduced_motion(const Model& model, const std::string& scene_path, const RomSettings& settings,
                              std::size_t max_rollouts) {
  return [&model, scene_path, settings, max_rollouts](const std::function<void(const PointSnapshot&)>& use) {
    const Scene scene = load_scene(scene_path);
    // The training runs of the scene's design, at most max_rollouts spread evenly over them.
    std::vector<RolloutCase> cases;
    const auto runs = scene.design.all_runs();
    for (std::size_t i = 0; i < runs.size(); ++i)
      if (std::find(scene.design.test_runs.begin(), scene.design.test_runs.end(), int(i)) ==
          scene.design.test_runs.end())
        cases.push_back({runs[i], "train"});
    if (cases.empty()) cases.push_back({{}, ""});  // a scene without a design: its one run
    const std::size_t stride = std::max<std::size_t>(1, (cases.size() + max_rollouts - 1) / max_rollouts);
    std::vector<RolloutCase> picked;
    for (std::size_t i = stride / 2; i < cases.size(); i += stride) picked.push_back(cases[i]);
    RomSettings all_points = settings;
    // The Galerkin step fits its own quantities (mass matrix, momentum, reduced force); the grid methods fit
    // Algorithm 1's (mass matrix, the sub-step's velocity increment)
    const bool galerkin = settings.method == RomMethod::Galerkin;
    all_points.method = galerkin ? RomMethod::Galerkin : RomMethod::MaterialPoint;
    all_points.samples = 0;
    all_points.weighting = SampleWeighting::Mass;
    all_points.end_time = 0;  // the training runs' horizon, whatever the rollouts' own (--end-time)
    std::vector<int> every(model.num_points());
    std::iota(every.begin(), every.end(), 0);
    const HyperReduction reduction = build_hyper_reduction(model, scene, all_points, every);
    auto stepper = impl::create_stepper(model, scene_path, scene.design.names, picked, all_points, reduction);
    const int r = model.latent_dim;
    const std::size_t P = model.num_points();
    std::vector<double> increment(P * 3);
    while (stepper->advance_frame()) {
      const auto inputs = stepper->last_projection_inputs();
      for (int b = 0; b < stepper->rollouts(); ++b) {
        if (stepper->flags(b) & rom::fatal_flags) continue;
        const double* J = &inputs.J[std::size_t(b) * P * 3 * r];
        if (galerkin) {
          use({J, {&inputs.velocity[std::size_t(b) * P * 3]}, &inputs.force[std::size_t(b) * P * r]});
          continue;
        }
        const double* rate = &inputs.rate_before[std::size_t(b) * r];
        // What the sub-step added to the manifold's velocity: the part the projection has to get right.
        for (std::size_t i = 0; i < P * 3; ++i) {
          double v = 0;
          for (int q = 0; q < r; ++q) v += J[i * r + q] * rate[q];
          increment[i] = inputs.velocity[std::size_t(b) * P * 3 + i] - v;
        }
        use({J, {increment.data()}});
      }
    }
  };
}

SnapshotStream snapshot_stream(const Model& model, const CubatureSnapshots& snapshots) {
  if (snapshots.data != nullptr) return training_runs(model, *snapshots.data, snapshots.count);
  if (snapshots.scene_path.empty())
    throw std::invalid_argument("cubature: neither training runs nor a scene to roll the reduced model out on");
  return reduced_motion(model, snapshots.scene_path, snapshots.settings, snapshots.count);
}

}  // namespace

CubatureSnapshots cubature_snapshots(const Scene& scene, const RomSettings& settings, const TrainingData* data) {
  CubatureSnapshots snapshots;
  if (settings.cubature_from_reduced_motion) {
    snapshots.scene_path = scene.source_path;
    snapshots.settings = settings;
    snapshots.count = 8;  // rollouts, each at every output frame
    return snapshots;
  }
  if (data == nullptr || data->train.runs.empty())
    throw std::invalid_argument("cubature from the full-order runs needs them: pass --data SWEEP_DIR");
  snapshots.data = data;
  return snapshots;
}

CubatureFit cubature_weights(const Model& model, const CubatureSnapshots& snapshots, const std::vector<int>& samples) {
  return solve(cubature_system(model, snapshot_stream(model, snapshots), samples), samples, 0, false);
}

CubatureFit cubature_selection(const Model& model, const CubatureSnapshots& snapshots, std::size_t count) {
  const std::vector<int> candidates = all_candidates(model);
  return solve(cubature_system(model, snapshot_stream(model, snapshots), candidates), candidates, count, true);
}

}  // namespace mpmrom
