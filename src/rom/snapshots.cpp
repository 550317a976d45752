// Where the offline fits' snapshots come from (docs/rom.md "Sample weights"): the full-order training runs, the
// all-point reduced model rolled out over the scene's training design, or one sub-step from each of the model's
// training states (at every point, or at the candidates alone on a large body).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/math/splitmix64.hpp"
#include "rom/detail/decoder.hpp"
#include "rom/detail/rollout_driver.hpp"
#include "rom/detail/snapshots.hpp"
#include "rom/detail/training_frames.hpp"
#include "rom/kernels/projection.hpp"

namespace mpmrom {
namespace {

using impl::PointSnapshot;
using impl::SnapshotStream;

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
      PointSnapshot snapshot{J.data(), {&run.v[frame.frame * P * 3], a.data()}};
      snapshot.run = int(frame.run);
      use(snapshot);
    }
  };
}

// Up to max_rollouts training runs of the scene's design (those `usable` keeps), spread evenly, with their design
// indices.
std::vector<RolloutCase> training_cases(const Scene& scene, std::size_t max_rollouts, std::vector<int>& indices,
                                        const std::function<bool(int)>& usable = {}) {
  std::vector<RolloutCase> cases;
  std::vector<int> all_indices;
  const auto runs = scene.design.all_runs();
  for (std::size_t i = 0; i < runs.size(); ++i)
    if (std::find(scene.design.test_runs.begin(), scene.design.test_runs.end(), int(i)) ==
            scene.design.test_runs.end() &&
        (!usable || usable(int(i))))
      cases.push_back({runs[i], "train"}), all_indices.push_back(int(i));
  if (runs.empty()) cases.push_back({{}, ""}), all_indices.push_back(0);  // a scene without a design: its one run
  const std::size_t stride = std::max<std::size_t>(1, (cases.size() + max_rollouts - 1) / max_rollouts);
  std::vector<RolloutCase> picked;
  indices.clear();
  for (std::size_t i = stride / 2; i < cases.size(); i += stride)
    picked.push_back(cases[i]), indices.push_back(all_indices[i]);
  return picked;
}

// A stepper of the method's snapshots over the cases, sampling `points` (every point, or the candidates of a large
// body): the Galerkin step fits its own quantities (mass matrix, momentum, reduced force), the grid methods the mass
// matrix and the sub-step's velocity increment of their own all-point step (Algorithm 2's quadrature transfers
// differ from Algorithm 1's particles'). Its node sets cover the motion of the training codes listed (empty: every
// code).
std::unique_ptr<impl::BatchStepperBase> snapshot_stepper(const Model& model, const std::string& scene_path,
                                                         const Scene& scene, const RomSettings& settings,
                                                         const std::vector<RolloutCase>& cases,
                                                         const std::vector<int>& points,
                                                         const std::vector<int>& codes = {}) {
  RomSettings sampled = settings;
  sampled.samples = points.size() == model.num_points() ? 0 : int(points.size());
  sampled.weighting = SampleWeighting::Mass;
  sampled.end_time = 0;  // the training runs' horizon, whatever the rollouts' own (--end-time)
  // Each sub-step's terms at its own state (a leapfrog takes them half a step on): the fits serve either integrator.
  sampled.integrator = TimeIntegrator::SymplecticEuler;
  const HyperReduction reduction = build_hyper_reduction(model, scene, sampled, points, codes);
  return impl::create_stepper(model, scene_path, scene.design.names, cases, sampled, reduction);
}

std::vector<int> every_point(const Model& model) {
  std::vector<int> every(model.num_points());
  std::iota(every.begin(), every.end(), 0);
  return every;
}

// Hands each running rollout's last sub-step to use: J of its final pass with the velocity that sub-step added to
// the manifold's (the part the projection has to get right), or the Galerkin step's momentum and reduced force, at
// the stepper's samples: every point, or the candidates standing for their cells.
void use_last_substep(const impl::BatchStepperBase& stepper, const impl::Candidates* candidates, std::size_t P,
                      bool galerkin, const std::function<void(const PointSnapshot&)>& use) {
  const int r = stepper.latent_dim();
  const std::vector<int>* points = candidates ? &candidates->points : nullptr;
  const std::vector<double>* masses = candidates ? &candidates->masses : nullptr;
  const std::size_t S = points ? points->size() : P;
  const auto inputs = stepper.last_projection_inputs();
  std::vector<double> increment(S * 3);
  for (int b = 0; b < stepper.rollouts(); ++b) {
    if (stepper.flags(b) & rom::fatal_flags) continue;
    const double* J = &inputs.J[std::size_t(b) * S * 3 * std::size_t(r)];
    if (galerkin) {
      PointSnapshot snapshot{J,
                             {&inputs.velocity[std::size_t(b) * S * 3]},
                             &inputs.force[std::size_t(b) * S * std::size_t(r)],
                             points,
                             masses};
      snapshot.run = b;
      use(snapshot);
      continue;
    }
    const double* rate = &inputs.rate_before[std::size_t(b) * std::size_t(r)];
    for (std::size_t i = 0; i < S * 3; ++i) {
      double v = 0;
      for (int q = 0; q < r; ++q) v += J[i * std::size_t(r) + std::size_t(q)] * rate[q];
      increment[i] = inputs.velocity[std::size_t(b) * S * 3 + i] - v;
    }
    PointSnapshot snapshot{J, {increment.data()}, nullptr, points, masses};
    snapshot.run = b;
    use(snapshot);
  }
}

// The Galerkin step's snapshot of one sub-step from `state` with the grid step's reduced force as the all-point
// target (CubatureTarget::Grid): both steppers advance one sub-step from the state; the Galerkin stepper gives J at
// its trial state, the momentum J^T v_n and the forces q at its rows (every point, or the candidates), the grid
// stepper (Algorithm 1 with every point) the force its sub-step applied, sum_p m_p J_trial^T (v_G2P - v_n) / dt over
// the whole body, which the samples' q must reproduce. Summed over every point, not over the candidates: the two
// steps' per-point terms are different integrands of one weak form, equal only summed over the body.
void use_grid_target(impl::BatchStepperBase& galerkin, impl::BatchStepperBase& grid, const impl::BatchState& state,
                     const impl::Candidates* candidates, const Model& model,
                     const std::function<void(const PointSnapshot&)>& use) {
  galerkin.restore(state);
  const double dt = galerkin.probe_substep();
  grid.restore(state);
  if (dt <= 0 || grid.probe_substep() != dt) throw std::logic_error("cubature: the two steps' time steps differ");
  const std::size_t r = std::size_t(galerkin.latent_dim()), P = model.num_points();
  const std::size_t S = candidates ? candidates->points.size() : P;
  const auto own = galerkin.last_projection_inputs(), moved = grid.last_projection_inputs();
  // v_n at every point: the Galerkin step's own where its rows are every point, else J at the state's codes
  const std::vector<double> J_before =
      candidates ? impl::decoder_jacobians(model, model.X, state.xhat) : std::vector<double>();
  std::vector<double> target(r);
  for (int b = 0; b < galerkin.rollouts(); ++b) {
    if ((galerkin.flags(b) | grid.flags(b)) & rom::fatal_flags) continue;
    std::fill(target.begin(), target.end(), 0.0);
    for (std::size_t p = 0; p < P; ++p) {
      const std::size_t point = std::size_t(b) * P + p;
      for (std::size_t d = 0; d < 3; ++d) {
        double v_n = 0;
        if (candidates)
          for (std::size_t q = 0; q < r; ++q) v_n += J_before[(point * 3 + d) * r + q] * state.xhatdot[b * r + q];
        else
          v_n = own.velocity[point * 3 + d];
        const double change = model.mass[p] * (moved.velocity[point * 3 + d] - v_n) / dt;
        for (std::size_t k = 0; k < r; ++k) target[k] += moved.J[(point * 3 + d) * r + k] * change;
      }
    }
    const std::size_t first = std::size_t(b) * S;
    PointSnapshot snapshot{&own.J[first * 3 * r],
                           {&own.velocity[first * 3]},
                           &own.force[first * r],
                           candidates ? &candidates->points : nullptr,
                           candidates ? &candidates->masses : nullptr};
    snapshot.reduced_target_sum = target.data();
    snapshot.run = b;
    use(snapshot);
  }
}

// The grid step's stepper for the Galerkin step's snapshots with CubatureTarget::Grid (null: its own target).
std::unique_ptr<impl::BatchStepperBase> grid_target_stepper(const Model& model, const std::string& scene_path,
                                                            const Scene& scene, const RomSettings& settings,
                                                            const std::vector<RolloutCase>& cases,
                                                            const std::vector<int>& points,
                                                            const std::vector<int>& codes = {}) {
  if (settings.method != RomMethod::Galerkin || settings.cubature_target != CubatureTarget::Grid) return nullptr;
  RomSettings grid = settings;
  grid.method = RomMethod::MaterialPoint;
  grid.cubature_target = CubatureTarget::Own;
  grid.galerkin_strain = GalerkinStrain::Continuum;
  grid.galerkin_transfer = false;
  grid.galerkin_node_average = false;
  return snapshot_stepper(model, scene_path, scene, grid, cases, points, codes);
}

// The spread (standard deviation) of each latent coordinate over the model's codes: the scale of the motion along it.
std::vector<double> code_spread(const Model& model) {
  const std::size_t r = std::size_t(model.latent_dim), n = model.num_codes();
  std::vector<double> mean(r, 0.0), spread(r, 0.0);
  for (std::size_t c = 0; c < n; ++c)
    for (std::size_t q = 0; q < r; ++q) mean[q] += model.codes[c * r + q] / double(n);
  for (std::size_t c = 0; c < n; ++c)
    for (std::size_t q = 0; q < r; ++q) spread[q] += std::pow(model.codes[c * r + q] - mean[q], 2) / double(n);
  for (double& s : spread) s = std::sqrt(s);
  return spread;
}

// A forward difference's step, relative to the code spread: small enough that the increments' response is linear
// (their grid transfer is C1 in the positions), large enough that float rounding stays far below it.
constexpr double sensitivity_step = 1e-2;

// The increments' response to one latent coordinate k a rollout, by a forward difference from `state` (whose
// sub-step the stepper has just probed): (increment(xhat + h e_k) - increment(xhat)) s_k / h with J at xhat, s_k the
// code spread, so that it says how the increments change over the motion's scale along k. Rollout b takes
// k = (turn + b) mod r: over the states the responses cover every coordinate at one probe a state, not r. Emits the
// probed sub-step's own snapshots first when emit_base.
void use_sensitivities(const Model& model, impl::BatchStepperBase& stepper, const impl::BatchState& state,
                       const impl::Candidates* candidates, std::size_t turn, bool emit_base,
                       const std::function<void(const PointSnapshot&)>& use) {
  const std::size_t r = std::size_t(model.latent_dim), P = model.num_points();
  const std::size_t values = (candidates ? candidates->points.size() : P) * 3;
  const std::size_t rollouts = std::size_t(stepper.rollouts());
  std::vector<std::vector<double>> J(rollouts), base(rollouts);
  use_last_substep(stepper, candidates, P, false, [&](const PointSnapshot& snapshot) {
    if (emit_base) use(snapshot);
    J[std::size_t(snapshot.run)].assign(snapshot.J, snapshot.J + values * r);
    base[std::size_t(snapshot.run)].assign(snapshot.fields[0], snapshot.fields[0] + values);
  });
  const std::vector<double> spread = code_spread(model);
  std::vector<double> step(rollouts, 0.0);
  impl::BatchState moved = state;
  for (std::size_t b = 0; b < rollouts; ++b) {
    const std::size_t k = (turn + b) % r;
    step[b] = sensitivity_step * spread[k];  // 0 along a coordinate the training motion never moves along
    moved.xhat[b * r + k] += step[b];
  }
  stepper.restore(moved);
  stepper.probe_substep();
  std::vector<double> response(values);
  use_last_substep(stepper, candidates, P, false, [&](const PointSnapshot& snapshot) {
    const std::size_t b = std::size_t(snapshot.run);
    if (base[b].empty() || !(step[b] > 0)) return;  // the base sub-step failed, or no motion along k
    const double scale = spread[(turn + b) % r] / step[b];
    for (std::size_t i = 0; i < values; ++i) response[i] = (snapshot.fields[0][i] - base[b][i]) * scale;
    PointSnapshot sensitivity{J[b].data(), {response.data()}, nullptr, snapshot.points, snapshot.row_masses};
    sensitivity.run = snapshot.run;
    sensitivity.sensitivity = true;
    use(sensitivity);
  });
}

// The all-point reduced model over at most max_rollouts of the scene's training design, at every output frame.
SnapshotStream reduced_motion(const Model& model, const std::string& scene_path, const RomSettings& settings,
                              std::size_t max_rollouts, bool responses) {
  return [&model, scene_path, settings, max_rollouts, responses](const std::function<void(const PointSnapshot&)>& use) {
    const Scene scene = load_scene(scene_path);
    std::vector<int> indices;
    const auto cases = training_cases(scene, max_rollouts, indices);
    auto stepper = snapshot_stepper(model, scene_path, scene, settings, cases, every_point(model));
    auto grid = grid_target_stepper(model, scene_path, scene, settings, cases, every_point(model));
    if (!grid) {
      while (stepper->advance_frame()) {
        use_last_substep(*stepper, nullptr, model.num_points(), settings.method == RomMethod::Galerkin, use);
        const impl::BatchState state = stepper->state();
        if (!responses || state.frame + 1 >= stepper->frames()) continue;
        stepper->restore(state);  // the responses are taken from the frame's state, then the motion goes on from it
        stepper->probe_substep();
        use_sensitivities(model, *stepper, state, nullptr, std::size_t(state.frame), false, use);
        stepper->restore(state);
      }
      return;
    }
    // The grid step's all-point motion, both steps probed from each of its output frames.
    while (grid->advance_frame()) {
      const impl::BatchState state = grid->state();
      if (state.frame + 1 >= grid->frames()) break;
      use_grid_target(*stepper, *grid, state, nullptr, model, use);
      grid->restore(state);
    }
  };
}

// The training codes a probe from each run's state at the given frames can move through: the code there and its
// neighbours in time (the rate is their central difference), so that the probing steppers' node sets cover those
// states alone, not the whole training motion (at 10^6 points and 936 codes, 22 GB of positions and a host scan of
// each point at each code: docs/rom.md "Sample weights").
std::vector<int> probed_codes(const Model& model, const std::vector<int>& indices, const std::vector<int>& frames) {
  std::set<int> codes;
  for (const int index : indices) {
    const std::vector<std::size_t> run = impl::codes_of_run(model, index);
    for (const int f : frames)
      for (int g = f - 1; g <= f + 1; ++g)
        if (g >= 0 && std::size_t(g) < run.size()) codes.insert(int(run[std::size_t(g)]));
  }
  return {codes.begin(), codes.end()};
}

// One sub-step from the model's own training states (every point, or the candidates of a larger body): for up to
// max_rollouts training runs of the scene's design, at up to --cubature-frames inner output frames spread evenly, xhat
// the run's code there and xhatdot the central difference of its codes (as training defines the rate). Each snapshot
// costs one sub-step, not a rollout: the source that scales.
SnapshotStream training_states(const Model& model, const std::string& scene_path, const RomSettings& settings,
                               std::size_t max_rollouts, std::size_t max_candidates, bool responses) {
  return [&model, scene_path, settings, max_rollouts, max_candidates,
          responses](const std::function<void(const PointSnapshot&)>& use) {
    const Scene scene = load_scene(scene_path);
    std::vector<int> indices;
    // A body larger than the candidates is sampled at them alone (J at 2048 points instead of every one).
    const impl::Candidates candidates = impl::all_candidates(model, max_candidates);
    const bool sampled = candidates.points.size() < model.num_points();
    const auto cases = impl::trained_cases(model, scene, max_rollouts, indices);
    const std::vector<int> rows = sampled ? candidates.points : every_point(model);
    const int frames = scene.num_outputs + 1;  // the initial state and each output time
    const std::vector<int> frames_probed = impl::inner_frames(frames, settings.cubature_frames);
    const std::vector<int> codes = probed_codes(model, indices, frames_probed);
    auto stepper = snapshot_stepper(model, scene_path, scene, settings, cases, rows, codes);
    auto grid = grid_target_stepper(model, scene_path, scene, settings, cases, every_point(model), codes);
    if (stepper->frames() != frames) throw std::logic_error("cubature: the stepper's frames are not the scene's");
    impl::BatchState state = stepper->state();
    for (const int f : frames_probed) {
      state.frame = f;
      impl::training_state(model, indices, f, stepper->frames(), state.xhat, state.xhatdot);
      if (grid) {
        use_grid_target(*stepper, *grid, state, sampled ? &candidates : nullptr, model, use);
        continue;
      }
      stepper->restore(state);
      stepper->probe_substep();
      if (responses)
        use_sensitivities(model, *stepper, state, sampled ? &candidates : nullptr, std::size_t(f), true, use);
      else
        use_last_substep(*stepper, sampled ? &candidates : nullptr, model.num_points(),
                         settings.method == RomMethod::Galerkin, use);
    }
  };
}

}  // namespace

namespace impl {

// The model's codes of design run `index` (its file named run_<index>.h5 by the sweep), by time.
std::vector<std::size_t> codes_of_run(const Model& model, int index) {
  std::vector<std::size_t> codes;
  for (std::size_t c = 0; c < model.num_codes(); ++c) {
    const std::string& path = model.runs[std::size_t(model.code_run[c])];
    const std::size_t stem = path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/') + 1;
    if (path.compare(stem, 4, "run_") != 0) continue;
    if (std::atoi(path.c_str() + stem + 4) == index) codes.push_back(c);
  }
  std::sort(codes.begin(), codes.end(),
            [&](std::size_t a, std::size_t b) { return model.code_time[a] < model.code_time[b]; });
  return codes;
}

std::vector<RolloutCase> trained_cases(const Model& model, const Scene& scene, std::size_t max_rollouts,
                                       std::vector<int>& indices) {
  // the runs the model was trained on (the pipeline holds some of the design's training runs out to validate)
  auto cases =
      training_cases(scene, max_rollouts, indices, [&model](int index) { return !codes_of_run(model, index).empty(); });
  if (cases.empty())
    throw std::runtime_error(
        "cubature: the model holds the codes of none of the scene's training runs (the training states are the "
        "model's codes of the sweep's run_<index>.h5)");
  return cases;
}

std::vector<int> inner_frames(int frames, int max_frames) {
  const int inner = frames - 2, stride = std::max(1, (inner + max_frames - 1) / std::max(1, max_frames));
  std::vector<int> picked;
  for (int f = 1 + (inner - 1) % stride / 2; f + 1 < frames; f += stride) picked.push_back(f);
  return picked;
}

void training_state(const Model& model, const std::vector<int>& indices, int frame, int frames,
                    std::vector<double>& xhat, std::vector<double>& xhatdot) {
  const std::size_t r = std::size_t(model.latent_dim), f = std::size_t(frame);
  xhat.resize(indices.size() * r);
  xhatdot.resize(indices.size() * r);
  for (std::size_t b = 0; b < indices.size(); ++b) {
    const std::vector<std::size_t> codes = codes_of_run(model, indices[b]);
    if (codes.size() != std::size_t(frames))
      throw std::runtime_error("cubature: the model holds " + std::to_string(codes.size()) + " codes of design run " +
                               std::to_string(indices[b]) + ", the scene " + std::to_string(frames) + " frames");
    const double* before = &model.codes[codes[f - 1] * r];
    const double* now = &model.codes[codes[f] * r];
    const double* after = &model.codes[codes[f + 1] * r];
    const double span = model.code_time[codes[f + 1]] - model.code_time[codes[f - 1]];
    for (std::size_t q = 0; q < r; ++q) {
      xhat[b * r + q] = now[q];
      xhatdot[b * r + q] = (after[q] - before[q]) / span;
    }
  }
}

std::vector<std::size_t> PointSnapshot::rows_of(const std::vector<int>& wanted) const {
  std::vector<std::size_t> rows;
  if (!points) return {wanted.begin(), wanted.end()};
  for (const int p : wanted) {
    const auto it = std::lower_bound(points->begin(), points->end(), p);  // the candidates are in increasing order
    if (it == points->end() || *it != p)
      throw std::invalid_argument("offline fit: point " + std::to_string(p) +
                                  " is not among the snapshots' candidate points (on a body this large the snapshots "
                                  "hold the candidates alone: use --selection greedy-projection or cubature)");
    rows.push_back(std::size_t(it - points->begin()));
  }
  return rows;
}

SnapshotStream snapshot_stream(const Model& model, const CubatureSnapshots& snapshots, bool responses) {
  if (responses && (snapshots.data != nullptr || snapshots.settings.method == RomMethod::Galerkin))
    throw std::logic_error("snapshots: responses are taken of the grid methods' reduced sub-steps alone");
  if (snapshots.data != nullptr) return training_runs(model, *snapshots.data, snapshots.count);
  if (snapshots.scene_path.empty())
    throw std::invalid_argument("cubature: neither training runs nor a scene to roll the reduced model out on");
  if (snapshots.settings.snapshot_source == SnapshotSource::States)
    return training_states(model, snapshots.scene_path, snapshots.settings, snapshots.count, snapshots.max_candidates,
                           responses);
  return reduced_motion(model, snapshots.scene_path, snapshots.settings, snapshots.count, responses);
}

// Spread in space, not in index: a stride through the points' lattice order aliases with it (on the 10^5 cylinder,
// 80 points a column, a stride of 50 kept 8 of the 80 heights and none of the loaded top 5 cm). The cell size is
// bisected to the smallest whose occupied cells number at most max_candidates; each cell gives one of its points,
// which stands for the cell's mass.
Candidates all_candidates(const Model& model, std::size_t max_candidates) {
  const std::size_t P = model.num_points();
  Candidates candidates;
  if (P <= max_candidates) {
    candidates.points.resize(P);
    std::iota(candidates.points.begin(), candidates.points.end(), 0);
    candidates.masses = model.mass;
    return candidates;
  }
  double lo[3], extent = 0;
  for (int d = 0; d < 3; ++d) {
    double hi = lo[d] = model.X[std::size_t(d)];
    for (std::size_t p = 0; p < P; ++p) {
      lo[d] = std::min(lo[d], model.X[3 * p + std::size_t(d)]);
      hi = std::max(hi, model.X[3 * p + std::size_t(d)]);
    }
    extent = std::max(extent, hi - lo[d]);
  }
  // One point of each occupied cell of size h, keyed by the cell (at most 2^20 cells an axis): the one of smallest
  // hash, a fixed draw uniform over the cell's points, so that the candidates take every position the points have
  // relative to the grid and the surface (the point nearest the centre never took the outer layer).
  struct Cell {
    int point;
    std::uint64_t draw;
    double mass;
  };
  const auto cells = [&](double h) {
    std::unordered_map<std::uint64_t, Cell> drawn;
    for (std::size_t p = 0; p < P; ++p) {
      std::uint64_t key = 0;
      for (int d = 0; d < 3; ++d) {
        const double u = (model.X[3 * p + std::size_t(d)] - lo[d]) / h;
        key = (key << 21) | std::uint64_t(std::min(std::floor(u), double((1 << 20) - 1)));
      }
      const std::uint64_t draw = splitmix64_mix(p);
      const auto [it, fresh] = drawn.emplace(key, Cell{int(p), draw, 0.0});
      if (!fresh && draw < it->second.draw) it->second.point = int(p), it->second.draw = draw;
      it->second.mass += model.mass[p];
    }
    return drawn;
  };
  double fine = extent / double(1 << 20), coarse = 2 * extent;  // too many cells at `fine`, one at `coarse`
  for (int iteration = 0; iteration < 30 && coarse > 1.01 * fine; ++iteration) {
    const double h = std::sqrt(fine * coarse);
    (cells(h).size() > max_candidates ? fine : coarse) = h;
  }
  std::vector<std::pair<int, double>> picked;
  for (const auto& [key, cell] : cells(coarse)) picked.emplace_back(cell.point, cell.mass);
  std::sort(picked.begin(), picked.end());
  for (const auto& [point, mass] : picked) candidates.points.push_back(point), candidates.masses.push_back(mass);
  return candidates;
}

}  // namespace impl

CubatureSnapshots cubature_snapshots(const Scene& scene, const RomSettings& settings, const TrainingData* data) {
  CubatureSnapshots snapshots;
  snapshots.max_candidates = std::size_t(settings.cubature_candidates);
  if (settings.snapshot_source != SnapshotSource::Full) {
    snapshots.scene_path = scene.source_path;
    snapshots.settings = settings;
    // The Galerkin step's weights reproduce a force, which the grid step measures at the scene's time step and not
    // beyond it (its velocity change over a longer step is no longer the force: docs/results/rom/README.md).
    if (settings.method == RomMethod::Galerkin && settings.cfl > scene.cfl) snapshots.settings.cfl = 0;
    snapshots.count = std::size_t(settings.cubature_runs);  // rollouts (training runs)
    return snapshots;
  }
  if (data == nullptr || data->train.runs.empty())
    throw std::invalid_argument("cubature from the full-order runs needs them: pass --data SWEEP_DIR");
  snapshots.data = data;
  return snapshots;
}

}  // namespace mpmrom
