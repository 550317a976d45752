// How the reduced model's batch kernels lay (rollout, point) items over a team: `threads` team threads of `lanes`
// vector lanes, each thread taking `rounds` items one after the other through the network (its lanes sharing an
// item), after which the team's threads and lanes take the items' stresses one each. On host backends a team is one
// thread of one lane taking one item; on GPUs a team is about 128 threads and its scratch stays within 48 KiB.
#pragma once

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <cstddef>
#include <stdexcept>
#include <string>

#include "core/kokkos_compat.hpp"
#include "manifold/nn/mlp_kinematics.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom::rom {

inline constexpr std::size_t team_scratch_alignment = 64;      // bytes: a block of eight channels in double
inline constexpr std::size_t team_scratch_budget = 48 * 1024;  // bytes: what every CUDA GPU grants a block
inline constexpr int kinematics_values = int(sizeof(nn::PointKinematics<real_t>) / sizeof(real_t));

struct TeamShape {
  int threads = 1, lanes = 1, rounds = 1;
  KOKKOS_INLINE_FUNCTION int items() const { return threads * rounds; }
};

// Values rounded up to whole scratch alignment blocks.
KOKKOS_INLINE_FUNCTION int aligned_values(int values) {
  constexpr int block = int(team_scratch_alignment / sizeof(real_t));
  return (values + block - 1) / block * block;
}

// Scratch of a team: values shared by the team, per thread, and per item (after the threads' own).
struct TeamScratch {
  int shared = 0, per_thread = 0, per_item = 0;

  KOKKOS_INLINE_FUNCTION long values(const TeamShape& shape) const {
    return long(aligned_values(shared)) + long(shape.threads) * aligned_values(per_thread) +
           long(aligned_values(shape.items() * per_item));
  }
  std::size_t bytes(const TeamShape& shape) const {
    return std::size_t(values(shape)) * sizeof(real_t) + team_scratch_alignment;  // room to align the start
  }
  // This team's block, its shared part first, then its threads' parts, then the items'. Each call takes a new block
  // from the team's scratch, which holds one: a kernel calls it once and hands the block on (a second call gets null).
  template <class Member>
  KOKKOS_INLINE_FUNCTION real_t* base(const Member& member, const TeamShape& shape) const {
    return static_cast<real_t*>(
        member.team_scratch(0).get_shmem_aligned(std::size_t(values(shape)) * sizeof(real_t), team_scratch_alignment));
  }
  KOKKOS_INLINE_FUNCTION real_t* thread_part(real_t* base, int thread) const {
    return base + aligned_values(shared) + thread * aligned_values(per_thread);
  }
  KOKKOS_INLINE_FUNCTION real_t* item_part(real_t* base, const TeamShape& shape) const {
    return base + aligned_values(shared) + shape.threads * aligned_values(per_thread);
  }
};

// Whether a GPU launch of `items` items is latency-bound: a warp for each item still fits the GPU's resident threads,
// so the launch waits on one item's passes through the network. False on host backends.
template <class ExecutionSpace>
bool few_items(long items, const ExecutionSpace& space = {}) {
  if (Kokkos::SpaceAccessibility<Kokkos::HostSpace, typename ExecutionSpace::memory_space>::accessible) return false;
  constexpr int warp = 32;
  return items * warp <= long(compat::concurrency(space));
}

// Lanes per item: for few items a warp an item (a 48-wide layer then takes one pass of its lanes instead of three);
// else `lanes`, which wastes the fewest lanes when the items fill the GPU.
template <class ExecutionSpace>
int lanes_for_items(long items, int lanes, const ExecutionSpace& space = {}) {
  return few_items(items, space) ? std::max(lanes, 32) : lanes;
}

// The shape for `items` items on a manifold that wants `lanes` lanes per item and this scratch: on GPUs 128 / lanes
// threads (fewer if the scratch would not fit) taking up to `lanes` items each, so that the stress phase has one item
// per lane; fewer rounds when the items would not fill the GPU otherwise (a short round trip matters more then).
template <class ExecutionSpace>
TeamShape team_shape(long items, int lanes, const TeamScratch& scratch, const ExecutionSpace& space = {}) {
  if (Kokkos::SpaceAccessibility<Kokkos::HostSpace, typename ExecutionSpace::memory_space>::accessible)
    return TeamShape{};
  TeamShape shape{std::max(1, 128 / lanes), lanes, lanes};
  while (shape.threads > 1 && scratch.bytes(shape) > team_scratch_budget) shape.threads /= 2;
  if (scratch.bytes(shape) > team_scratch_budget)
    throw std::runtime_error("the network needs " + std::to_string(scratch.bytes(shape)) +
                             " bytes of team scratch, more than the " + std::to_string(team_scratch_budget) +
                             " the reduced model's kernels may use: use a narrower network");
  // rounds such that the teams' threads and lanes number about the GPU's resident threads
  const long resident = compat::concurrency(space);
  shape.rounds = int(std::max(1L, std::min(long(lanes), items * lanes / std::max(1L, resident))));
  return shape;
}

}  // namespace mpmrom::rom
