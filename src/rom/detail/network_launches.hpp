// The launches that run the network at the samples and at the grid strain's nodes, one thread an item or on teams
// (team_launches.hpp says which), or on CPUs in blocks of points, as free templates on the execution space. Private to
// the rom stage.
#pragma once

#include <Kokkos_Core.hpp>

#include "core/math/simd.hpp"
#include "manifold/device_data.hpp"
#include "rom/detail/grid_strain.hpp"
#include "rom/detail/team_launches.hpp"
#include "rom/kernels/galerkin.hpp"
#include "rom/kernels/sources.hpp"

namespace mpmrom::impl {

// Positions (into `positions`) and dg/dxhat (into J) of the samples at X (samples, 3), every rollout's at its xhat.
template <class ExecutionSpace, class Manifold>
void launch_sample_kinematics(const ExecutionSpace& space, const Manifold& manifold,
                              const TeamLaunch<Manifold, ExecutionSpace>& launch, const DeviceMatrix& X,
                              const DeviceMatrix& xhat, const DeviceCube& positions, const DeviceQuad& J) {
  const long items = long(xhat.extent(0)) * long(X.extent(0));
  const rom::SampleKinematics<Manifold, ExecutionSpace> samples{launch.manifold, X, xhat, positions, J, launch.shape,
                                                                launch.scratch};
  if constexpr (Kokkos::SpaceAccessibility<Kokkos::HostSpace, DeviceMemory>::accessible && math::host_lane_blocks) {
    const long blocks = (items + nn::host_block_lanes - 1) / nn::host_block_lanes;
    Kokkos::parallel_for("mpmrom::rom::sample_kinematics", LightRange<ExecutionSpace>(space, 0, blocks),
                         rom::BlockSampleKinematics<Manifold, ExecutionSpace>{samples});
    return;
  }
  if (one_thread_tangents<ExecutionSpace>(manifold, items))
    Kokkos::parallel_for("mpmrom::rom::sample_kinematics", LightRange<ExecutionSpace>(space, 0, items), samples);
  else
    Kokkos::parallel_for("mpmrom::rom::sample_kinematics", launch_teams(space, items, launch), samples);
}

// The grid strain's nodes: their displacements and dg/dxhat at xhat (rom::GridStrainNodeKinematics). Where teams run
// them and `samples` has items (the launch sized for both), the samples' kinematics at xhat in the same launch.
template <class ExecutionSpace, class Manifold>
void launch_strain_nodes(const ExecutionSpace& space, const Manifold& manifold,
                         const TeamLaunch<Manifold, ExecutionSpace>& launch, const GridStrainViews& strain,
                         const DeviceMatrix& xhat, const Kokkos::View<int*, DeviceMemory>& flags, bool node_average,
                         const rom::SampleKinematics<Manifold, ExecutionSpace>& samples) {
  constexpr bool host_space = Kokkos::SpaceAccessibility<Kokkos::HostSpace, DeviceMemory>::accessible;
  const long items = long(xhat.extent(0)) * long(strain.nodes.extent(0));
  const rom::GridStrainNodeKinematics<Manifold, DeviceMemory> one{manifold, strain.nodes, xhat,
                                                                  strain.u, strain.dg,    flags};
  if constexpr (host_space && math::host_lane_blocks) {
    const long blocks = (items + nn::host_block_lanes - 1) / nn::host_block_lanes;
    Kokkos::parallel_for("mpmrom::rom::grid_strain_nodes", LightRange<ExecutionSpace>(space, 0, blocks),
                         rom::BlockGridStrainNodeKinematics<Manifold, DeviceMemory>{one});
    return;
  }
  if (host_space || one_thread_tangents<ExecutionSpace>(manifold, items)) {
    Kokkos::parallel_for("mpmrom::rom::grid_strain_nodes", LightRange<ExecutionSpace>(space, 0, items), one);
    return;
  }
  const rom::TeamGridStrainNodeKinematics<Manifold, ExecutionSpace> nodes{
      launch.manifold, strain.nodes, xhat, strain.u, strain.dg, launch.shape, launch.scratch, node_average};
  const long sample_items = long(samples.xhat.extent(0)) * long(samples.X.extent(0));
  if (sample_items == 0)
    Kokkos::parallel_for("mpmrom::rom::grid_strain_nodes", launch_teams(space, items, launch), nodes);
  else
    Kokkos::parallel_for("mpmrom::rom::grid_strain_nodes_and_samples",
                         launch_teams(space, items + sample_items, launch),
                         rom::TeamNodesAndSamples<Manifold, ExecutionSpace>{nodes, samples});
}

}  // namespace mpmrom::impl
