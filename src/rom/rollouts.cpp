// The reduced model's rollouts: the batch's stepper (the one translation unit that instantiates its kernels, for the
// trained network), its initial state, and the run through the output frames with checkpoints, on one process or
// shared over MPI ranks.
#include <Kokkos_Core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/math/cholesky.hpp"
#include "core/parallel.hpp"
#include "core/timing.hpp"
#include "manifold/device_data.hpp"
#include "manifold/trainer.hpp"
#include "rom/detail/decoder.hpp"
#include "rom/detail/rom_stepper.hpp"
#include "rom/detail/share_wire.hpp"
#include "scene/sampling.hpp"

namespace mpmrom {
namespace {

using MemorySpace = Kokkos::DefaultExecutionSpace::memory_space;
using Vector = impl::DeviceVector;
using impl::upload;

// The network padded for one thread a point (nn::RegisterMlp), on the device.
Kokkos::View<const nn::WeightQuad<real_t>*, MemorySpace> upload_quads(const nn::MlpLayout& layout,
                                                                      const std::vector<double>& weights) {
  const std::vector<real_t> padded = nn::arrange_for_registers<real_t>(layout, weights);
  Kokkos::View<nn::WeightQuad<real_t>*, MemorySpace> quads("mpmrom::rom::register_params", padded.size() / 4);
  const auto host = Kokkos::create_mirror_view(quads);
  for (std::size_t i = 0; i < padded.size(); ++i) host(i / 4).v[i % 4] = padded[i];
  Kokkos::deep_copy(quads, host);
  return quads;
}

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
    const double spin[3] = {w[1] * arm[2] - w[2] * arm[1], w[2] * arm[0] - w[0] * arm[2],
                            w[0] * arm[1] - w[1] * arm[0]};
    for (int d = 0; d < 3; ++d) {
      v[3 * p + d] = samples.velocity[3 * p + d];
      moving = moving || v[3 * p + d] != 0.0 || spin[d] != 0.0;
    }
  }
  if (!moving) return;
  const auto Jh = impl::decoder_jacobians(model, model.X, xhat);
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

// One batch shares the grid, the material and the output times; its rollouts differ in loads only. Throws for
// rollout c's scene when it differs from the first's in more.
void check_same_batch(const Scene& scene, const Scene& first, std::size_t c) {
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
  if (reduction.samples.empty() || (reduction.nodes.empty() && settings.method != RomMethod::Galerkin))
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
      check_same_batch(scene, first, c);
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
  nn::RegisterMlp<real_t, MemorySpace> narrow{team.layout.num_layers, team.layout.latent_dim, team.standardization, {}};
  if (nn::RegisterMlp<real_t, MemorySpace>::fits(team.layout)) narrow.quads = upload_quads(team.layout, model.weights);
  std::unique_ptr<impl::BatchStepperBase> stepper;
  nn::dispatch_max_width(model.layout().widest, [&](auto width) {
    using Manifold = rom::MlpManifold<decltype(width)::value, MemorySpace>;
    stepper = std::make_unique<impl::BatchStepper<Manifold>>(
        Manifold{impl::device_mlp(model, params), team, narrow}, model.latent_dim,
        impl::ReferencePoints{model.X, model.mass, model.volume}, first, loads, xhat0, xhatdot0, settings,
        max_latent_speed, reduction);
  });
  return stepper;
}

void impl::record_rollouts(BatchStepperBase& stepper, RomResult& result,
                           const std::function<void(const RomProgress&)>& progress, const RolloutCheckpoint& checkpoint,
                           const std::string& identity, const parallel::Communicator& comm) {
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
  if (comm.size() > 1) stepper.share_time_step([&comm](double* values, std::size_t count) { comm.max(values, count); });
  const bool checkpointing = !checkpoint.path.empty();
  if (!(checkpointing && checkpoint.resume && resume_from_checkpoint(stepper, result, checkpoint.path, identity, comm)))
    record();
  auto last_checkpoint = SteadyClock::now();
  while (stepper.advance_frame()) {
    record();
    if (progress) progress({stepper.frame(), int(frames) - 1, stepper.time(), stepper.steps(), stepper.step_seconds()});
    // every rank asks, so that all checkpoint at the same frame
    if (checkpointing && stepper.frame() + 1 < int(frames) &&
        comm.any(seconds_since(last_checkpoint) >= checkpoint.seconds)) {
      save_checkpoint(stepper, result, checkpoint.path, identity, comm);
      last_checkpoint = SteadyClock::now();
    }
  }
  stepper.share_time_step({});
  result.steps = stepper.steps();
  result.step_seconds = stepper.step_seconds();
  result.outcomes = stepper.outcomes();
  result.evaluated_points = stepper.evaluated_points();
}

namespace {

// The rollouts of cases (a batch, or under comm of several ranks this rank's share of one) on this process.
RomResult run_share(const parallel::Communicator& comm, const Model& model, const std::string& scene_path,
                    const std::vector<std::string>& names, const std::vector<RolloutCase>& cases,
                    const RomSettings& settings, const HyperReduction& reduction,
                    const std::function<void(const RomProgress&)>& progress, const RolloutCheckpoint& checkpoint) {
  const auto start = SteadyClock::now();
  RomResult result;
  result.parameter_names = names;
  result.cases = cases;
  result.latent_dim = model.latent_dim;
  const auto stepper = impl::create_stepper(model, scene_path, names, cases, settings, reduction);
  stepper->warm_up();
  result.setup_seconds = comm.max(seconds_since(start));
  impl::record_rollouts(*stepper, result, comm.is_root() ? progress : std::function<void(const RomProgress&)>(),
                        checkpoint,
                        checkpoint.path.empty() ? "" : batch_identity(model, scene_path, names, cases, settings), comm);
  const auto warnings = training_range_warnings(model, names, cases);
  for (std::size_t c = 0; c < cases.size(); ++c) result.outcomes[c].warning = warnings[c];
  result.step_seconds = comm.max(result.step_seconds);  // the ranks step together: the slowest one's time
  return result;
}

}  // namespace

RomResult run_rollouts(const Model& model, const std::string& scene_path, const std::vector<std::string>& names,
                       const std::vector<RolloutCase>& cases, const RomSettings& settings,
                       const HyperReduction& reduction, const std::function<void(const RomProgress&)>& progress,
                       const RolloutCheckpoint& checkpoint) {
  return run_share(parallel::Communicator::self(), model, scene_path, names, cases, settings, reduction, progress,
                   checkpoint);
}

RomResult run_rollouts(const parallel::Communicator& comm, const Model& model, const std::string& scene_path,
                       const std::vector<std::string>& names, const std::vector<RolloutCase>& cases,
                       const RomSettings& settings, const HyperReduction& reduction,
                       const std::function<void(const RomProgress&)>& progress, const RolloutCheckpoint& checkpoint) {
  if (comm.size() == 1) return run_rollouts(model, scene_path, names, cases, settings, reduction, progress, checkpoint);
  if (cases.size() < std::size_t(comm.size()))
    throw std::runtime_error(std::to_string(cases.size()) + " rollout(s) cannot be shared by " +
                             std::to_string(comm.size()) + " processes: run with at most one process per rollout");
  const auto share = parallel::share_of(cases.size(), comm.rank(), comm.size());
  const std::vector<RolloutCase> mine(cases.begin() + long(share.begin), cases.begin() + long(share.end));
  RolloutCheckpoint own = checkpoint;
  own.path = checkpoint.path.empty() ? "" : rank_checkpoint_path(checkpoint.path, comm.rank(), comm.size());
  const RomResult result = run_share(comm, model, scene_path, names, mine, settings, reduction, progress, own);
  const auto parts = comm.gather(impl::share_bytes(result));
  if (!comm.is_root()) return result;
  RomResult whole = result;
  whole.cases = cases;
  whole.xhat.clear();
  whole.xhatdot.clear();
  whole.outcomes.clear();
  for (const auto& part : parts) impl::append_share(whole, part);
  return whole;
}

}  // namespace mpmrom
