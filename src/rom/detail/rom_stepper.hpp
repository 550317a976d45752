// The reduced model's time stepper, generic in the manifold (src/rom/kernels/manifold.hpp) so that tests can drive it
// with analytic maps; src/rom/rollouts.cpp instantiates it for the trained network. What its drivers call without
// the manifold's type is in rollout_driver.hpp. Private to the library and its tests.
#pragma once

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "fom/fom.hpp"
#include "rom/detail/device_array.hpp"
#include "rom/detail/rollout_counters.hpp"
#include "rom/detail/rollout_driver.hpp"
#include "rom/detail/grid_strain.hpp"
#include "rom/detail/network_launches.hpp"
#include "rom/detail/team_launches.hpp"
#include "manifold/device_data.hpp"
#include "rom/kernels/galerkin.hpp"
#include "rom/kernels/leapfrog.hpp"
#include "rom/kernels/projection.hpp"
#include "rom/outcome.hpp"
#include "rom/kernels/sources.hpp"
#include "rom/kernels/transfer.hpp"
#include "core/parallel.hpp"
#include "mpmrom/rom.hpp"

namespace mpmrom::impl {

template <class Manifold>
class BatchStepper final : public BatchStepperBase {
  using ExecutionSpace = Kokkos::DefaultExecutionSpace;
  using MemorySpace = ExecutionSpace::memory_space;
  using Vector = DeviceVector;
  using Matrix = DeviceMatrix;
  using Cube = DeviceCube;
  using Quad = DeviceQuad;
  using IndexView = Kokkos::View<int*, DeviceMemory>;
  static constexpr bool host_space = Kokkos::SpaceAccessibility<Kokkos::HostSpace, MemorySpace>::accessible;

 public:
  // The batch at (xhat0, xhatdot0) (rollouts x r, row-major) at time 0, to be advanced through the scene's output
  // times on manifold. max_latent_speed: the energy detector's limit on |xhatdot| (0: none).
  BatchStepper(const Manifold& manifold, int latent_dim, const ReferencePoints& model, const Scene& scene,
               const std::vector<rom::RolloutLoads>& host_loads, const std::vector<double>& xhat0,
               const std::vector<double>& xhatdot0, const RomSettings& settings, double max_latent_speed,
               const HyperReduction& h)
      : BatchStepperBase(int(host_loads.size()), latent_dim, output_times(scene)),
        manifold_(manifold),
        settings_(settings),
        B_(int(host_loads.size())),
        S_(int(h.samples.size())),
        I_(int(h.nodes.size())),
        point_method_(settings.method == RomMethod::MaterialPoint),
        galerkin_(settings.method == RomMethod::Galerkin),
        leapfrog_(galerkin_ && settings.integrator == TimeIntegrator::Leapfrog),
        K_(point_method_ ? int(h.source_points.size()) : int(h.quadrature_weight.size())),
        grid_(grid_for_scene(scene)),
        material_(material_for_scene(scene)),
        apic_(scene.transfer == TransferKind::APIC),
        wave_speed_(double(stable_time_step_wave_speed(material_, real_t(scene.material.density)))),
        cfl_(settings.cfl > 0 ? settings.cfl : scene.cfl),
        dx_(scene.dx),
        stable_dt_(h.stable_time_step),
        density_(real_t(scene.material.density)),
        domain_(reference_domain(scene)),
        max_failed_inversions_(int(std::floor(settings.max_failed_inversions * K_))),
        counters_(B_) {
    const int r = latent_dim, B = B_, S = S_, K = K_;
    std::vector<double> X_src, mass_src, volume_src, X_samples, weight_samples, force_weight_samples;
    for (const int p : h.source_points) {
      X_src.insert(X_src.end(), model.X.begin() + 3 * p, model.X.begin() + 3 * p + 3);
      mass_src.push_back(model.mass[p]);
      volume_src.push_back(model.volume[p]);
    }
    for (std::size_t i = 0; i < h.samples.size(); ++i) {
      const int s = h.samples[i];
      X_samples.insert(X_samples.end(), model.X.begin() + 3 * s, model.X.begin() + 3 * s + 3);
      weight_samples.push_back(h.weights.empty() ? model.mass[s] : h.weights[i]);
      force_weight_samples.push_back(h.force_weights.empty() ? weight_samples.back() : h.force_weights[i]);
    }
    points_X_ = upload<Matrix>("mpmrom::rom::source_X", X_src, X_src.size() / 3, 3);
    points_mass_ = upload<Vector>("mpmrom::rom::source_mass", mass_src, mass_src.size());
    points_volume_ = upload<Vector>("mpmrom::rom::source_volume", volume_src, volume_src.size());
    samples_X_ = upload<Matrix>("mpmrom::rom::samples_X", X_samples, S, 3);
    samples_weight_ = upload<Vector>("mpmrom::rom::samples_weight", weight_samples, S);
    samples_force_weight_ = upload<Vector>("mpmrom::rom::samples_force_weight", force_weight_samples, S);
    if (galerkin_) sample_force_ = Matrix("mpmrom::rom::sample_force", B, std::size_t(S) * r);
    if (galerkin_ && settings.galerkin_strain == GalerkinStrain::Grid)
      strain_ = upload_grid_strain(grid_strain_nodes(grid_, host_loads.at(0), times_.back(), model.X, model.mass,
                                                     X_samples, apic_, settings.galerkin_node_average),
                                   B, r);
    evaluated_points_ = std::size_t(point_method_ ? K : S + (galerkin_ ? int(strain_.nodes.extent(0)) : K));
    quadrature_x_ = upload<Matrix>("mpmrom::rom::quadrature_x", h.quadrature_x, h.quadrature_weight.size(), 3);
    quadrature_w_ = upload<Vector>("mpmrom::rom::quadrature_w", h.quadrature_weight, h.quadrature_weight.size());
    nodes_ = upload_indices("mpmrom::rom::nodes", h.nodes);
    offsets_ = upload_indices("mpmrom::rom::node_offsets", h.node_offsets);
    node_sources_ = upload_indices("mpmrom::rom::node_sources", h.node_sources);
    std::vector<int> slot_host(std::size_t(grid_.num_nodes()), -1);
    for (int n = 0; n < I_; ++n) slot_host[h.nodes[n]] = n;
    node_slot_ = upload_indices("mpmrom::rom::node_slot", slot_host);
    loads_ = Kokkos::View<rom::RolloutLoads*, MemorySpace>("mpmrom::rom::loads", B);
    {
      auto host = Kokkos::create_mirror_view(loads_);
      for (int b = 0; b < B; ++b) host(b) = host_loads[b];
      Kokkos::deep_copy(loads_, host);
    }
    xhat_ = upload<Matrix>("mpmrom::rom::xhat", xhat0, B, r);
    xhatdot_ = upload<Matrix>("mpmrom::rom::xhatdot", xhatdot0, B, r);
    sources_ = rom::make_sources<MemorySpace>("mpmrom::rom::sources", K, B);
    sample_x_ = Cube("mpmrom::rom::sample_x", B, S, 3);
    sample_v_ = Cube("mpmrom::rom::sample_v", B, S, 3);
    if (leapfrog_) start_v_ = Cube("mpmrom::rom::start_v", B, S, 3);
    sample_J_ = Quad("mpmrom::rom::sample_J", B, S, 3, r);
    node_v_ = Cube("mpmrom::rom::node_v", B, I_, 3);
    trial_x_ = Cube("mpmrom::rom::trial_x", B, S, 3);
    xhat_next_ = Matrix("mpmrom::rom::xhat_next", B, r);
    xhatdot_next_ = Matrix("mpmrom::rom::xhatdot_next", B, r);
    reference_ = Cube("mpmrom::rom::reference", point_method_ ? 0 : B, point_method_ ? 0 : K, 3);
    converged_ = Kokkos::View<unsigned char**, MemorySpace>("mpmrom::rom::converged", point_method_ ? 0 : B,
                                                            point_method_ ? 0 : K);
    fastest_sample_ = Kokkos::View<real_t, MemorySpace>("mpmrom::rom::fastest_sample");

    constexpr double epsilon = std::numeric_limits<real_t>::epsilon();
    guard_.max_condition = real_t(settings.max_condition > 0 ? settings.max_condition : 0.01 / epsilon);
    guard_.regularization = real_t(settings.regularization > 0 ? settings.regularization : 100 * epsilon);
    guard_.regularize = settings.regularize;
    guard_.max_latent_speed = real_t(max_latent_speed);
    newton_.tolerance = real_t(settings.newton_tolerance * scene.dx);
    newton_.max_iterations = settings.newton_iterations;

    using Sources = rom::MaterialPointSources<Manifold, ExecutionSpace>;
    using Samples = rom::SampleKinematics<Manifold, ExecutionSpace>;
    sources_launch_ = team_launch<ExecutionSpace>(manifold_, long(B) * K, false, Sources::scratch_for);
    if constexpr (Sources::host_blocks) sources_launch_.shape.rounds = nn::host_block_lanes;  // a block a team
    samples_launch_ = team_launch<ExecutionSpace>(manifold_, long(B) * S, true, Samples::scratch_for);
    // On GPUs the grid strain's nodes take the samples' kinematics at the same state into their launch, where teams
    // run it (rom::TeamNodesAndSamples).
    const long node_items = long(B) * long(strain_.nodes.extent(0));
    nodes_with_samples_ = !host_space && strain_.stencils.extent(0) > 0 && !settings.galerkin_node_average &&
                          !one_thread_tangents<ExecutionSpace>(manifold_, node_items + long(B) * S);
    nodes_launch_ = team_launch<ExecutionSpace>(manifold_, node_items + (nodes_with_samples_ ? long(B) * S : 0), true,
                                                Samples::scratch_for);
    // On GPUs, a batch too small to give each of a quarter of the resident threads a node gathers across lanes;
    // the projection takes its rows across lanes.
    if (!host_space) {
      gather_across_lanes_ = long(B) * I_ * 4 < long(compat::concurrency(ExecutionSpace()));
      projection_launch_.lanes = 32;
    }
  }

  bool advance_frame() override {
    if (frame_ + 1 >= frames()) return false;
    const auto start = std::chrono::steady_clock::now();
    const double target = times_[std::size_t(frame_ + 1)];
    double time = times_[std::size_t(frame_)];
    double max_speed = double(max_speed_);
    // Once every rollout has stopped there is nothing left to advance: the remaining frames repeat the last state.
    bool all_stopped = std::all_of(outcomes_.begin(), outcomes_.end(),
                                   [](const RolloutOutcome& o) { return (o.flags & rom::fatal_flags) != 0; });
    if (share_max_) {  // the fastest sample and whether any rollout runs, over the whole batch
      double shared[2] = {max_speed, all_stopped ? 0.0 : 1.0};
      share_max_(shared, 2);
      max_speed = shared[0];
      all_stopped = shared[1] == 0;
    }
    const double dt_max = max_time_step(max_speed);
    const long substeps = all_stopped ? 0 : std::max(1L, long(std::ceil((target - time) / dt_max - 1e-9)));
    const double dt_interval = substeps > 0 ? (target - time) / double(substeps) : 0.0;
    for (long sub = 0; sub < substeps; ++sub) {
      substep(real_t(time), real_t(dt_interval), leapfrog_);
      time = sub + 1 == substeps ? target : time + dt_interval;
      ++steps_;
    }
    if (substeps > 0) Kokkos::deep_copy(max_speed_, fastest_sample_);
    ++frame_;
    update_outcomes(target);
    step_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return true;
  }

  // The CFL number's step at the fastest sample's speed, within the reduced dynamics' bound.
  double max_time_step(double max_speed) const {
    const double cfl_step = cfl_ * dx_ / (wave_speed_ + max_speed);
    return stable_dt_ > 0 ? std::min(cfl_step, stable_dt_) : cfl_step;
  }

  double probe_substep() override {
    if (frame_ + 1 >= frames()) return 0;
    const real_t dt = interval_substep();
    substep(real_t(times_[std::size_t(frame_)]), dt, false);  // the terms at the state itself, which the fits probe
    return double(dt);
  }

  // On a GPU a kernel's first launch loads it and resolves its launch attributes: 6.8 ms of the first frame of a
  // 10^6-point rollout on an H200 (105 steps of 0.21 ms), which the step time would otherwise count as stepping.
  void warm_up() override {
    if (frame_ + 1 >= frames()) return;
    const BatchState saved = state();
    substep(real_t(times_[std::size_t(frame_)]), interval_substep(), leapfrog_);
    restore(saved);
  }

  // The current output interval's sub-step at the speed of the last frame's fastest sample, as advance_frame takes it.
  real_t interval_substep() const {
    const double interval = times_[std::size_t(frame_ + 1)] - times_[std::size_t(frame_)];
    return real_t(interval / std::max(1.0, std::ceil(interval / max_time_step(double(max_speed_)) - 1e-9)));
  }

  void latent(std::vector<double>& xhat, std::vector<double>& xhatdot) const override {
    xhat = download(xhat_);
    xhatdot = download(xhatdot_);
  }

  void latent_of(int rollout, std::vector<double>& xhat, std::vector<double>& xhatdot) const override {
    xhat = download(Kokkos::subview(xhat_, rollout, Kokkos::ALL));
    xhatdot = download(Kokkos::subview(xhatdot_, rollout, Kokkos::ALL));
  }

  DeviceArray latent_on_device(bool rate) const override { return device_snapshot(rate ? xhatdot_ : xhat_); }

  ProjectionInputs last_projection_inputs() const override {
    return {download(sample_J_), download(sample_v_), download(xhatdot_next_),  // swapped: the rate before
            galerkin_ ? download(sample_force_) : std::vector<double>()};
  }

  BatchState state() const override {
    BatchState saved;
    saved.frame = frame_;
    saved.steps = steps_;
    saved.step_seconds = step_seconds_;
    saved.max_speed = double(max_speed_);
    saved.xhat = download(xhat_);
    saved.xhatdot = download(xhatdot_);
    saved.reference = download(reference_);
    counters_.save(saved);
    saved.converged = download_ints(converged_);
    saved.outcomes = outcomes_;
    return saved;
  }

  void restore(const BatchState& saved) override {
    const std::size_t B = std::size_t(B_), r = std::size_t(latent_dim_);
    if (saved.frame < 0 || saved.frame >= frames() || saved.xhat.size() != B * r || saved.xhatdot.size() != B * r ||
        !counters_.fits(saved) || saved.outcomes.size() != B || saved.reference.size() != reference_.size() ||
        saved.converged.size() != converged_.size())
      throw std::runtime_error("the saved state is of another batch (frame or sizes differ)");
    frame_ = saved.frame;
    steps_ = saved.steps;
    step_seconds_ = saved.step_seconds;
    max_speed_ = real_t(saved.max_speed);
    fill_view(xhat_, saved.xhat);
    fill_view(xhatdot_, saved.xhatdot);
    fill_view(reference_, saved.reference);
    fill_view(converged_, saved.converged);
    counters_.restore(saved);
    outcomes_ = saved.outcomes;
  }

  std::vector<RolloutOutcome> outcomes() const override {
    std::vector<RolloutOutcome> result = outcomes_;
    counters_.report(result);
    return result;
  }

 private:
  static std::vector<double> output_times(const Scene& scene) {
    std::vector<double> times{0.0};
    for (int frame = 1; frame <= scene.num_outputs; ++frame)
      times.push_back(scene.end_time * frame / scene.num_outputs);
    return times;
  }

  using Range = LightRange<ExecutionSpace>;
  using Teams = LightTeams<ExecutionSpace>;

  // Positions (into `positions`) and dg/dxhat of the samples at xhat.
  void sample_kinematics(const ExecutionSpace& space, const Matrix& xhat, const Cube& positions) {
    launch_sample_kinematics(space, manifold_, samples_launch_, samples_X_, xhat, positions, sample_J_);
  }

  // The grid strain's nodes at xhat_ and, with nodes_with_samples_, the samples' kinematics at xhat_ in one launch.
  void move_strain_nodes(const ExecutionSpace& space) {
    const TeamLaunch<Manifold, ExecutionSpace>& launch = nodes_launch_;
    const auto samples = rom::SampleKinematics<Manifold, ExecutionSpace>{
        launch.manifold, samples_X_,    nodes_with_samples_ ? xhat_ : Matrix(), sample_x_, sample_J_,
        launch.shape,    launch.scratch};
    launch_strain_nodes(space, manifold_, launch, strain_, xhat_, counters_.flags, settings_.galerkin_node_average,
                        samples);
  }

  // Algorithms 1 and 2 up to the projection: sources, node velocities, the samples' velocities from the grid.
  void transfer(const ExecutionSpace& space, real_t t, real_t dt) {
    const int B = B_, S = S_, K = K_, I = I_;
    if (point_method_) {
      using PointSources = rom::MaterialPointSources<Manifold, ExecutionSpace>;
      Kokkos::parallel_for("mpmrom::rom::point_sources",
                           launch_teams(space, long(B) * K, sources_launch_, sources_launch_.shape.items()),
                           PointSources{sources_launch_.manifold, points_X_, points_mass_, points_volume_, xhat_,
                                        xhatdot_, loads_, material_, t, dt, apic_, sources_, sample_x_, sample_J_,
                                        counters_.flags, sources_launch_.shape, sources_launch_.scratch});
    } else {
      sample_kinematics(space, xhat_, sample_x_);
      Kokkos::parallel_for("mpmrom::rom::quadrature_sources", Range(space, 0, long(B) * K),
                           rom::QuadratureSources<Manifold, MemorySpace>{manifold_,
                                                                         quadrature_x_,
                                                                         quadrature_w_,
                                                                         domain_,
                                                                         density_,
                                                                         newton_,
                                                                         settings_.inversion_fallback,
                                                                         xhat_,
                                                                         xhatdot_,
                                                                         loads_,
                                                                         material_,
                                                                         t,
                                                                         dt,
                                                                         apic_,
                                                                         reference_,
                                                                         converged_,
                                                                         sources_,
                                                                         counters_.failures,
                                                                         counters_.step_failures,
                                                                         counters_.fallbacks,
                                                                         counters_.flags});
      Kokkos::parallel_for(
          "mpmrom::rom::check_inversions", Range(space, 0, B),
          rom::CheckInversions<MemorySpace>{counters_.step_failures, max_failed_inversions_, counters_.flags});
    }
    const rom::GatherNodeVelocities<MemorySpace> gather{grid_,  nodes_, offsets_, node_sources_, sources_,
                                                        loads_, t,      dt,       node_v_,       host_space ? 1 : 32};
    if (gather_across_lanes_)
      Kokkos::parallel_for("mpmrom::rom::gather_nodes", Teams(space, int((long(B) * I + 3) / 4), 4, 32), gather);
    else
      Kokkos::parallel_for("mpmrom::rom::gather_nodes", Range(space, 0, long(B) * I), gather);
    // Into a device View: only the last sub-step's speed is read (at the frame's end), so sub-steps never wait.
    Kokkos::parallel_reduce(
        "mpmrom::rom::g2p_samples", Range(space, 0, long(B) * S),
        rom::SampleVelocities<MemorySpace>{grid_, node_slot_, sample_x_, node_v_, sample_v_, counters_.flags},
        Kokkos::Max<real_t, MemorySpace>(fastest_sample_));
  }

  // The Galerkin step's per-sample forces, momenta and the fastest sample; with the grid strain on GPUs, a team per
  // (rollout, sample) summing its strain for a few items, one thread each once they fill the GPU (on the poke
  // cylinder's 10^4 rollouts on an H200, 2.08 ms a step against 3.53 ms with 64 items a team and their strain entries
  // summed by all its threads).
  void galerkin_terms(const ExecutionSpace& space, real_t t, real_t dt, bool strain_on_teams) {
    const rom::GalerkinSampleTerms<Manifold, MemorySpace> terms{
        manifold_,       samples_X_,
        xhat_,           xhatdot_,
        loads_,          material_,
        density_,        t,
        sample_x_,       sample_v_,
        sample_J_,       sample_force_,
        counters_.flags, strain_.stencils,
        strain_.u,       strain_.dg,
        grid_,           settings_.galerkin_transfer ? dt : real_t(0),
        strain_on_teams, settings_.galerkin_node_average};
    const auto fastest = Kokkos::Max<real_t, MemorySpace>(fastest_sample_);
    if (strain_on_teams && rom::few_items<ExecutionSpace>(long(B_) * S_, space)) {
      using TeamTerms = rom::TeamGalerkinSampleTerms<Manifold, ExecutionSpace>;
      Kokkos::parallel_reduce(
          "mpmrom::rom::galerkin_terms",
          Teams(space, B_ * S_, 32).set_scratch_size(0, Kokkos::PerTeam(TeamTerms::scratch_bytes())), TeamTerms{terms},
          fastest);
    } else {
      Kokkos::parallel_reduce("mpmrom::rom::galerkin_terms", Range(space, 0, long(B_) * S_), terms, fastest);
    }
  }

  // One time step of every rollout: the samples' velocities from the grid (paper Algorithms 1, 2) or their momenta
  // and reduced forces (Galerkin), then the projection. leapfrog: the Galerkin terms half a step on, at t + dt / 2,
  // the kick over the whole step and the projection's drift over the other half (docs/rom.md "Time step").
  void substep(real_t t, real_t dt, bool leapfrog) {
    const ExecutionSpace space;
    const int B = B_, r = latent_dim_;
    if (leapfrog) {
      sample_kinematics(space, xhat_, sample_x_);
      Kokkos::parallel_for("mpmrom::rom::start_velocities", Range(space, 0, long(B) * S_),
                           rom::TangentVelocities<MemorySpace>{sample_J_, xhatdot_, start_v_, counters_.flags});
      Kokkos::parallel_for("mpmrom::rom::half_drift", Range(space, 0, long(B) * r),
                           rom::DriftLatent<MemorySpace>{xhat_, xhatdot_, counters_.flags, dt / 2});
    }
    // On GPUs the grid strain's network runs on teams (one thread per item would run it alone); host builds keep
    // one thread per item, its faster one-pass evaluation.
    const bool strain_on_teams = !host_space && strain_.stencils.extent(0) > 0;
    if (galerkin_ && strain_.nodes.extent(0) > 0) move_strain_nodes(space);
    if (galerkin_ && strain_on_teams && !nodes_with_samples_) sample_kinematics(space, xhat_, sample_x_);
    if (galerkin_)
      galerkin_terms(space, leapfrog ? t + dt / 2 : t, dt, strain_on_teams);
    else
      transfer(space, t, dt);
    using Projection = rom::ProjectSamples<ExecutionSpace, MemorySpace>;
    const bool positions = settings_.projection == ProjectionScheme::Position;
    const auto project = [&](bool first_pass) {
      const Projection projection{r,
                                  samples_weight_,
                                  sample_J_,
                                  leapfrog ? start_v_ : sample_v_,
                                  sample_x_,
                                  trial_x_,
                                  xhat_,
                                  xhatdot_,
                                  xhat_next_,
                                  xhatdot_next_,
                                  guard_,
                                  real_t(settings_.rate_damping),
                                  dt,
                                  first_pass,
                                  positions && !first_pass,
                                  counters_.flags,
                                  counters_.max_condition,
                                  counters_.regularized,
                                  sample_force_,
                                  samples_force_weight_,
                                  leapfrog ? dt / 2 : real_t(0)};
      projection_launch_(space, B, r, projection);
    };
    project(true);
    // Re-project with J at the trial next state, so that the new state's own velocity field J(xhat_n+1) xhatdot
    // reproduces the transferred velocities (with J(xhat_n) the manifold's curvature is counted twice); the position
    // scheme moves the trial state onto the samples' updated positions as it goes. The Galerkin step carries the
    // momentum onto the trial state's tangent space the same way.
    for (int iteration = 0; iteration < settings_.projection_iterations; ++iteration) {
      sample_kinematics(space, xhat_next_, trial_x_);
      project(false);
    }
    std::swap(xhat_, xhat_next_);
    std::swap(xhatdot_, xhatdot_next_);
  }

  // Rollouts whose fatal flags went up in this frame stop here; the others have completed one more frame.
  void update_outcomes(double time) {
    const auto flags = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), counters_.flags);
    for (int b = 0; b < B_; ++b) {
      RolloutOutcome& outcome = outcomes_[b];
      const bool fatal = flags(b) & rom::fatal_flags;
      if (fatal && !(outcome.flags & rom::fatal_flags)) {
        outcome.stopped_at = time;
        outcome.message = "stopped at t = " + std::to_string(time) + " s: " + describe_flags(flags(b), true);
      }
      if (!fatal) outcome.frames_completed = frame_ + 1;
      outcome.flags = flags(b);
    }
  }

  Manifold manifold_;
  RomSettings settings_;
  int B_, S_, I_;
  bool point_method_, galerkin_, leapfrog_;
  bool nodes_with_samples_ = false;  // the samples' kinematics in the grid strain nodes' launch
  int K_;
  GridGeometry<real_t> grid_;
  ElasticMaterial<real_t> material_;
  bool apic_;
  double wave_speed_, cfl_, dx_;
  double stable_dt_;  // the reduced dynamics' bound (HyperReduction::stable_time_step; 0: none)
  real_t density_;
  rom::ReferenceDomain domain_;
  int max_failed_inversions_;
  rom::ProjectionGuard guard_;
  rom::NewtonSettings newton_;
  TeamLaunch<Manifold, ExecutionSpace> sources_launch_, samples_launch_, nodes_launch_;
  bool gather_across_lanes_ = false;
  ProjectionLaunch<ExecutionSpace> projection_launch_;
  real_t max_speed_ = 0;  // fastest sample at the end of the last frame, for the next frame's time step

  Matrix points_X_, samples_X_, quadrature_x_;
  Vector points_mass_, points_volume_, quadrature_w_, samples_weight_, samples_force_weight_;
  Matrix sample_force_;  // the Galerkin step's reduced force per unit mass at each sample (rollouts, samples * r)
  IndexView nodes_, offsets_, node_sources_, node_slot_;
  Kokkos::View<rom::RolloutLoads*, MemorySpace> loads_;
  Matrix xhat_, xhatdot_, xhat_next_, xhatdot_next_;
  rom::SourceView<MemorySpace> sources_;
  Cube sample_x_, sample_v_, node_v_, trial_x_, reference_;
  Cube start_v_;            // the leapfrog's samples' velocities at the step's start (empty otherwise)
  GridStrainViews strain_;  // the Galerkin step's grid strain (GalerkinStrain::Grid; empty otherwise)
  Quad sample_J_;
  Kokkos::View<unsigned char**, MemorySpace> converged_;
  RolloutCounters<MemorySpace> counters_;
  Kokkos::View<real_t, MemorySpace> fastest_sample_;
};

// Advances the batch from (xhat0, xhatdot0) (rollouts x r, row-major) through the scene's output times on manifold,
// filling result's times, latent trajectories, outcomes and step timing. max_latent_speed: the energy detector's
// limit on |xhatdot| (0: none).
template <class Manifold>
void step_batch(const Manifold& manifold, int latent_dim, const ReferencePoints& model, const Scene& scene,
                const std::vector<rom::RolloutLoads>& host_loads, const std::vector<double>& xhat0,
                const std::vector<double>& xhatdot0, const RomSettings& settings, double max_latent_speed,
                const HyperReduction& h, RomResult& result, const std::function<void(const RomProgress&)>& progress) {
  BatchStepper<Manifold> stepper(manifold, latent_dim, model, scene, host_loads, xhat0, xhatdot0, settings,
                                 max_latent_speed, h);
  record_rollouts(stepper, result, progress);
}

}  // namespace mpmrom::impl
