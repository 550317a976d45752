// The reduced model's time stepper, generic in the manifold (kernels/rom/manifold.hpp) so that tests can drive it
// with analytic maps; src/rom.cpp instantiates it for the trained network. Private to the library and its tests.
#pragma once

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "fom.hpp"
#include "impl/device_data.hpp"
#include "kernels/rom/projection.hpp"
#include "kernels/rom/sources.hpp"
#include "kernels/rom/transfer.hpp"
#include "rom.hpp"

namespace mpmrom::impl {

// The full-order material points (row-major X (n, 3), mass and reference volume (n)) the reduced model stands for.
struct ReferencePoints {
  const std::vector<double>& X;
  const std::vector<double>& mass;
  const std::vector<double>& volume;
};

// One rollout's loads: forces as force per unit of the points' mass in each force region, as the full-order model
// shares them.
rom::RolloutLoads loads_for_scene(const Scene& scene, const ReferencePoints& points);
// The scene's bodies as the reference solid of Algorithm 2.
rom::ReferenceDomain reference_domain(const Scene& scene);
// One line naming the causes behind fatal rollout flags.
std::string describe_flags(int flags);
// Sets the scene's horizon to end_time rounded to whole output intervals, keeping the interval (--end-time).
void apply_horizon(Scene& scene, double end_time);

// Node set, neighbours and quadrature points for the samples, from positions (configurations, P, 3) of the motion
// the model covers. next[c], if given, is the configuration that follows c in time (-1 at a run's end): the sets then
// cover the straight path between the two, not just the output times.
HyperReduction hyper_reduction_from_motion(const Scene& scene, const RomSettings& settings,
                                           const std::vector<int>& samples, const std::vector<double>& positions,
                                           std::size_t P, const std::vector<int>& next = {});

// Advances the batch from (xhat0, xhatdot0) (rollouts x r, row-major) through the scene's output times on manifold,
// filling result's times, latent trajectories, outcomes and step timing. max_latent_speed: the energy detector's
// limit on |xhatdot| (0: none).
template <class Manifold>
void step_batch(const Manifold& manifold, int latent_dim, const ReferencePoints& model, const Scene& scene,
                const std::vector<rom::RolloutLoads>& host_loads,
                const std::vector<double>& xhat0, const std::vector<double>& xhatdot0, const RomSettings& settings,
                double max_latent_speed, const HyperReduction& h, RomResult& result, const std::function<void(const RomProgress&)>& progress) {
  using ExecutionSpace = Kokkos::DefaultExecutionSpace;
  using MemorySpace = ExecutionSpace::memory_space;
  using Vector = DeviceVector;
  using Matrix = DeviceMatrix;
  using Cube = DeviceCube;
  using Quad = DeviceQuad;
  using Clock = std::chrono::steady_clock;
  const auto seconds_since = [](Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
  };
  const ExecutionSpace space;
  const int B = int(host_loads.size()), r = latent_dim;
  const int S = int(h.samples.size()), I = int(h.nodes.size());
  const bool point_method = settings.method == RomMethod::MaterialPoint;
  const int K = point_method ? int(h.source_points.size()) : int(h.quadrature_weight.size());
  const GridGeometry<real_t> grid = grid_for_scene(scene);
  const ElasticMaterial<real_t> material = material_for_scene(scene);
  const bool apic = scene.transfer == TransferKind::APIC;
  const real_t wave_speed = stable_time_step_wave_speed(material, real_t(scene.material.density));
  const double cfl = settings.cfl > 0 ? settings.cfl : scene.cfl;
  constexpr double epsilon = std::numeric_limits<real_t>::epsilon();

  // Static data.
  std::vector<double> X_src, mass_src, volume_src, X_samples;
  for (const int p : h.source_points) {
    X_src.insert(X_src.end(), model.X.begin() + 3 * p, model.X.begin() + 3 * p + 3);
    mass_src.push_back(model.mass[p]);
    volume_src.push_back(model.volume[p]);
  }
  for (const int s : h.samples) X_samples.insert(X_samples.end(), model.X.begin() + 3 * s, model.X.begin() + 3 * s + 3);
  const Matrix points_X = upload<Matrix>("mpmrom::rom::source_X", X_src, X_src.size() / 3, 3);
  const Vector points_mass = upload<Vector>("mpmrom::rom::source_mass", mass_src, mass_src.size());
  const Vector points_volume = upload<Vector>("mpmrom::rom::source_volume", volume_src, volume_src.size());
  const Matrix samples_X = upload<Matrix>("mpmrom::rom::samples_X", X_samples, S, 3);
  const Matrix quadrature_x =
      upload<Matrix>("mpmrom::rom::quadrature_x", h.quadrature_x, h.quadrature_weight.size(), 3);
  const Vector quadrature_w =
      upload<Vector>("mpmrom::rom::quadrature_w", h.quadrature_weight, h.quadrature_weight.size());
  const auto nodes = upload_indices("mpmrom::rom::nodes", h.nodes);
  const auto offsets = upload_indices("mpmrom::rom::node_offsets", h.node_offsets);
  const auto node_sources = upload_indices("mpmrom::rom::node_sources", h.node_sources);
  std::vector<int> slot_host(std::size_t(grid.num_nodes()), -1);
  for (int n = 0; n < I; ++n) slot_host[h.nodes[n]] = n;
  const auto node_slot = upload_indices("mpmrom::rom::node_slot", slot_host);
  Kokkos::View<rom::RolloutLoads*, MemorySpace> loads("mpmrom::rom::loads", B);
  {
    auto host = Kokkos::create_mirror_view(loads);
    for (int b = 0; b < B; ++b) host(b) = host_loads[b];
    Kokkos::deep_copy(loads, host);
  }

  // State and work arrays.
  std::vector<double> xhat_all, xhatdot_all;
  for (int b = 0; b < B; ++b) {
    xhat_all.insert(xhat_all.end(), xhat0.begin() + std::size_t(b) * r, xhat0.begin() + std::size_t(b + 1) * r);
    xhatdot_all.insert(xhatdot_all.end(), xhatdot0.begin() + std::size_t(b) * r,
                       xhatdot0.begin() + std::size_t(b + 1) * r);
  }
  const Matrix xhat = upload<Matrix>("mpmrom::rom::xhat", xhat_all, B, r);
  const Matrix xhatdot = upload<Matrix>("mpmrom::rom::xhatdot", xhatdot_all, B, r);
  rom::SourceView<MemorySpace> sources("mpmrom::rom::sources", B, K, rom::source_size);
  Cube sample_x("mpmrom::rom::sample_x", B, S, 3), sample_v("mpmrom::rom::sample_v", B, S, 3);
  Quad sample_J("mpmrom::rom::sample_J", B, S, 3, r);
  Cube node_v("mpmrom::rom::node_v", B, I, 3), trial_x("mpmrom::rom::trial_x", B, S, 3);
  Matrix xhat_next("mpmrom::rom::xhat_next", B, r), xhatdot_next("mpmrom::rom::xhatdot_next", B, r);
  Cube reference("mpmrom::rom::reference", point_method ? 0 : B, point_method ? 0 : K, 3);
  Kokkos::View<unsigned char**, MemorySpace> converged("mpmrom::rom::converged", point_method ? 0 : B,
                                                      point_method ? 0 : K);
  Kokkos::View<int*, MemorySpace> failures("mpmrom::rom::failures", B), flags("mpmrom::rom::flags", B);
  Kokkos::View<int*, MemorySpace> step_failures("mpmrom::rom::step_failures", B);
  Kokkos::View<int*, MemorySpace> fallbacks("mpmrom::rom::fallbacks", B);
  const int max_failed_inversions = int(std::floor(settings.max_failed_inversions * K));
  Vector max_condition("mpmrom::rom::max_condition", B);
  Kokkos::View<int*, MemorySpace> regularized("mpmrom::rom::regularized", B);

  rom::ProjectionGuard guard;
  guard.max_condition = real_t(settings.max_condition > 0 ? settings.max_condition : 0.01 / epsilon);
  guard.regularization = real_t(settings.regularization > 0 ? settings.regularization : 100 * epsilon);
  guard.regularize = settings.regularize;
  guard.max_latent_speed = real_t(max_latent_speed);
  rom::NewtonSettings newton;
  newton.tolerance = real_t(settings.newton_tolerance * scene.dx);
  newton.max_iterations = settings.newton_iterations;
  const rom::ReferenceDomain domain = reference_domain(scene);

  const int frames = scene.num_outputs + 1;
  result.times.clear();
  result.xhat.assign(std::size_t(B) * frames * r, 0.0);
  result.xhatdot.assign(std::size_t(B) * frames * r, 0.0);
  result.outcomes.assign(B, RolloutOutcome{});
  std::vector<int> host_flags(B, 0);
  const auto record = [&](int frame) {
    const auto xh = download(xhat), xd = download(xhatdot);
    auto hf = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), flags);
    for (int b = 0; b < B; ++b) {
      RolloutOutcome& outcome = result.outcomes[b];
      const bool fatal = hf(b) & rom::fatal_flags;
      if (!fatal) outcome.frames_completed = frame + 1;
      for (int q = 0; q < r; ++q) {
        const std::size_t at = (std::size_t(b) * frames + frame) * r + q;
        result.xhat[at] = xh[std::size_t(b) * r + q];  // a stopped rollout keeps its last good state
        result.xhatdot[at] = xd[std::size_t(b) * r + q];
      }
    }
  };
  const auto check_flags = [&](double time) {
    auto hf = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), flags);
    for (int b = 0; b < B; ++b) {
      if ((hf(b) & rom::fatal_flags) && !(host_flags[b] & rom::fatal_flags)) {
        result.outcomes[b].stopped_at = time;
        result.outcomes[b].message = "stopped at t = " + std::to_string(time) + " s: " + describe_flags(hf(b));
      }
      host_flags[b] = hf(b);
    }
  };

  const auto start = Clock::now();
  double time = 0;
  real_t max_speed = 0;
  Kokkos::View<real_t, MemorySpace> fastest_sample("mpmrom::rom::fastest_sample");
  result.times.push_back(0.0);
  record(0);
  for (int frame = 1; frame < frames; ++frame) {
    const double target = scene.end_time * frame / scene.num_outputs;
    const double dt_max = cfl * scene.dx / (double(wave_speed) + double(max_speed));
    // Once every rollout has stopped there is nothing left to advance: the remaining frames repeat the last state.
    const bool all_stopped = std::all_of(host_flags.begin(), host_flags.end(),
                                         [](int f) { return (f & rom::fatal_flags) != 0; });
    const long substeps =
        all_stopped ? 0 : std::max(1L, long(std::ceil((target - time) / dt_max - 1e-9)));
    const double dt_interval = substeps > 0 ? (target - time) / double(substeps) : 0.0;
    for (long sub = 0; sub < substeps; ++sub) {
      const real_t t = real_t(time), dt = real_t(dt_interval);
      if (point_method) {
        Kokkos::parallel_for(
            "mpmrom::rom::point_sources", Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(space, 0, long(B) * K),
            rom::MaterialPointSources<Manifold, MemorySpace>{
                manifold, points_X, points_mass, points_volume, xhat, xhatdot, loads, material, t, dt, apic, sources,
                sample_x, sample_J, flags});
      } else {
        Kokkos::parallel_for(
            "mpmrom::rom::sample_kinematics",
            Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(space, 0, long(B) * S),
            rom::SampleKinematics<Manifold, MemorySpace>{manifold, samples_X, xhat, xhatdot, sample_x,
                                                                    sample_J});
        Kokkos::parallel_for(
            "mpmrom::rom::quadrature_sources",
            Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(space, 0, long(B) * K),
            rom::QuadratureSources<Manifold, MemorySpace>{
                manifold, quadrature_x, quadrature_w, domain, real_t(scene.material.density), newton,
                settings.inversion_fallback, xhat, xhatdot, loads, material, t, dt, apic, reference, converged,
                sources, failures, step_failures, fallbacks, flags});
        Kokkos::parallel_for("mpmrom::rom::check_inversions", Kokkos::RangePolicy<ExecutionSpace>(space, 0, B),
                             rom::CheckInversions<MemorySpace>{step_failures, max_failed_inversions, flags});
      }
      Kokkos::parallel_for("mpmrom::rom::gather_nodes",
                           Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(space, 0, long(B) * I),
                           rom::GatherNodeVelocities<MemorySpace>{grid, nodes, offsets, node_sources, sources, loads,
                                                                  t, dt, node_v});
      // Into a device View: only the last sub-step's speed is read (at the frame's end), so sub-steps never wait.
      Kokkos::parallel_reduce(
          "mpmrom::rom::g2p_samples", Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(space, 0, long(B) * S),
          rom::SampleVelocities<MemorySpace>{grid, node_slot, sample_x, node_v, sample_v, flags},
          Kokkos::Max<real_t, MemorySpace>(fastest_sample));
      using Projection = rom::ProjectVelocities<ExecutionSpace, MemorySpace>;
      const auto project = [&]() {
        Kokkos::parallel_for("mpmrom::rom::project",
                             Kokkos::TeamPolicy<ExecutionSpace>(space, B, Kokkos::AUTO)
                                 .set_scratch_size(0, Kokkos::PerTeam(Projection::scratch_bytes(r))),
                             Projection{r, sample_J, sample_v, xhat, xhat_next, xhatdot_next, guard, dt, flags,
                                        max_condition, regularized});
      };
      Kokkos::deep_copy(space, xhat_next, xhat);
      Kokkos::deep_copy(space, xhatdot_next, xhatdot);
      project();
      // Re-project with J at the trial next state, so that the new state's own velocity field J(xhat_n+1) xhatdot
      // reproduces the transferred velocities (with J(xhat_n) the manifold's curvature is counted twice).
      for (int iteration = 0; iteration < settings.projection_iterations; ++iteration) {
        Kokkos::parallel_for(
            "mpmrom::rom::sample_jacobians",
            Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(space, 0, long(B) * S),
            rom::SampleKinematics<Manifold, MemorySpace>{manifold, samples_X, xhat_next, xhatdot_next,
                                                                    trial_x, sample_J});
        project();
      }
      Kokkos::deep_copy(space, xhat, xhat_next);
      Kokkos::deep_copy(space, xhatdot, xhatdot_next);
      time = sub + 1 == substeps ? target : time + dt_interval;
      ++result.steps;
    }
    if (all_stopped) time = target;
    if (substeps > 0) Kokkos::deep_copy(max_speed, fastest_sample);
    check_flags(time);
    result.times.push_back(target);
    record(frame);
    if (progress) progress({frame, frames - 1, time, result.steps, seconds_since(start)});
  }
  Kokkos::fence();
  result.step_seconds = seconds_since(start);
  const auto hc = download(max_condition);
  auto hr = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), regularized);
  auto hfail = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), failures);
  auto hfallback = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), fallbacks);
  for (int b = 0; b < B; ++b) {
    RolloutOutcome& outcome = result.outcomes[b];
    outcome.flags = host_flags[b];
    outcome.max_condition = hc[b];
    outcome.regularized_steps = hr(b);
    outcome.inversion_failures = hfail(b);
    outcome.inversion_fallbacks = hfallback(b);
  }
}


}  // namespace mpmrom::impl
