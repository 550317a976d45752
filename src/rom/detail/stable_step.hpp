// The Galerkin step's time-step bound from its reduced dynamics (rom/stable_step.cpp; docs/rom.md "Time step").
#pragma once

#include "mpmrom/rom.hpp"

namespace mpmrom::impl {

// The training runs the bound probes, at up to max_state_frames (rom/detail/snapshots.hpp) frames each.
inline constexpr int stable_step_runs = 8;

// The reduced dynamics' highest angular frequency over the model's training states (up to stable_step_runs training
// runs of the scene's design, up to 8 inner output frames each, spread evenly): the largest sqrt(lambda) of K v =
// lambda M v, with M = sum_s w_s J_s^T J_s and K the symmetric part of minus the central differences in xhat of the
// weighted force sum_s wf_s q_s, for the rollout's samples and weights. 0 when no state has a positive eigenvalue.
double reduced_highest_frequency(const Model& model, const Scene& scene, const RomSettings& settings,
                                 const HyperReduction& reduction);

}  // namespace mpmrom::impl
