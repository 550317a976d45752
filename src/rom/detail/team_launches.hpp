// How the batch stepper lays its network kernels over GPU teams: for each launch (the material point sources, the
// samples' kinematics, the grid strain's nodes) the manifold as that launch reads its weights, the team scratch and
// the team shape. Private to the rom stage.
#pragma once

#include <algorithm>

#include "core/light_launch.hpp"
#include "rom/kernels/manifold.hpp"
#include "rom/kernels/sources.hpp"
#include "rom/kernels/team_shape.hpp"

namespace mpmrom::impl {

template <class Manifold, class ExecutionSpace>
struct TeamLaunch {
  Manifold manifold;
  rom::TeamScratch scratch;
  rom::TeamShape shape;
};

// A launch of `items` points whose kernel needs scratch_of(manifold) of team scratch, lanes_for_items' lanes each
// (with_lanes) or the manifold's own. The weights go to team scratch where they take at most half of it, or where
// the launch is latency-bound (few enough items for a warp each) and they fit beside one thread's buffers; a launch
// that fills the GPU reads them through the caches, keeping more threads resident (measured on the poke cylinder's
// 10^4-rollout batches: 1.35x slower staged; a 2-rollout step at 10^5 points 1.37x faster).
template <class ExecutionSpace, class Manifold, class ScratchOf>
TeamLaunch<Manifold, ExecutionSpace> team_launch(const Manifold& manifold, long items, bool with_lanes,
                                                 const ScratchOf& scratch_of) {
  const ExecutionSpace space;
  const int lanes =
      with_lanes ? rom::lanes_for_items<ExecutionSpace>(items, manifold.team_lanes(), space) : manifold.team_lanes();
  TeamLaunch<Manifold, ExecutionSpace> launch{manifold.with_staging(false), {}, {}};
  if (!Kokkos::SpaceAccessibility<Kokkos::HostSpace, typename ExecutionSpace::memory_space>::accessible &&
      manifold.staged_bytes() > 0) {
    const Manifold staged = manifold.with_staging(true);
    const bool fits = scratch_of(staged).bytes(rom::TeamShape{1, lanes, lanes}) <= rom::team_scratch_budget;
    const bool small = 2 * manifold.staged_bytes() <= rom::team_scratch_budget;
    if (fits && (small || rom::few_items(items, space))) launch.manifold = staged;
  }
  launch.scratch = scratch_of(launch.manifold);
  launch.shape = rom::team_shape<ExecutionSpace>(items, lanes, launch.scratch, space);
  return launch;
}

// Every launch takes its functor as a kernel argument (core/light_launch.hpp).
template <class ExecutionSpace>
using LightRange = Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>, LightWeight>;
template <class ExecutionSpace>
using LightTeams = Kokkos::TeamPolicy<ExecutionSpace, LightWeight>;

// A team per so many items of a launch (its shape's threads by default), with its lanes and scratch.
template <class ExecutionSpace, class Manifold>
LightTeams<ExecutionSpace> launch_teams(const ExecutionSpace& space, long items,
                                        const TeamLaunch<Manifold, ExecutionSpace>& launch, int per_team = 0) {
  const rom::TeamShape& shape = launch.shape;
  if (per_team == 0) per_team = shape.threads;
  return LightTeams<ExecutionSpace>(space, int((items + per_team - 1) / per_team), shape.threads, shape.lanes)
      .set_scratch_size(0, Kokkos::PerTeam(launch.scratch.bytes(shape)));
}

// Whether `items` points' positions and dg/dxhat take one thread each: where the manifold's one-thread evaluation
// is the faster and the items fill the GPU (for a few, a team thread's lanes sharing each point finish sooner: on
// the poke cylinder's 30 samples at batch 1, 12 us a launch against 17 us on an H200).
template <class ExecutionSpace, class Manifold>
bool one_thread_tangents(const Manifold& manifold, long items) {
  return manifold.thread_tangent() && !rom::few_items<ExecutionSpace>(items, ExecutionSpace());
}

// How the projection (rom::ProjectSamples) runs: on GPUs a team per rollout, a team thread per row of the normal
// equations, as many as the kernel's registers allow (the team's threads stride over the rows: at r = 16 a team of
// 16 x 32 exceeded them on an H200; asked once, the query costs a driver call), or one thread a rollout for a batch
// that fills the GPU (10^4 rollouts on an H200: 1.05 ms a launch on teams, whose registers keep two resident an SM,
// 0.27 ms so); host teams are one thread.
template <class ExecutionSpace>
struct ProjectionLaunch {
  static constexpr bool host_space =
      Kokkos::SpaceAccessibility<Kokkos::HostSpace, typename ExecutionSpace::memory_space>::accessible;
  int lanes = 1;
  int threads = 0;  // GPU teams' threads; 0: not asked yet

  template <class Projection>
  void operator()(const ExecutionSpace& space, int rollouts, int r, const Projection& projection) {
    if (!host_space && !rom::few_items<ExecutionSpace>(rollouts, space)) {
      Kokkos::parallel_for("mpmrom::rom::project", Kokkos::RangePolicy<ExecutionSpace, LightWeight>(space, 0, rollouts),
                           projection);
      return;
    }
    const auto scratch = Kokkos::PerTeam(Projection::scratch_bytes());
    if (threads == 0)
      threads = host_space ? 1
                           : std::min(r, LightTeams<ExecutionSpace>(space, rollouts, 1, lanes)
                                             .set_scratch_size(0, scratch)
                                             .team_size_max(projection, Kokkos::ParallelForTag()));
    Kokkos::parallel_for("mpmrom::rom::project",
                         (host_space ? LightTeams<ExecutionSpace>(space, rollouts, Kokkos::AUTO, lanes)
                                     : LightTeams<ExecutionSpace>(space, rollouts, threads, lanes))
                             .set_scratch_size(0, scratch),
                         projection);
  }
};

}  // namespace mpmrom::impl
