// The greedy projection's trial sets, told apart by the motion they give (rom/selection_trials.cpp; docs/rom.md
// "Sample selection"). Private to the rom stage.
#pragma once

#include <functional>
#include <string>

#include "mpmrom/rom.hpp"

namespace mpmrom::impl {

// How far the hyper-reduced rollouts of `fit` (its samples, and its weights where settings fit them) over up to
// settings.cubature_runs of the training runs the model holds stay from the model's own codes of those runs: the
// mass-weighted RMS distance between the positions the two decode at the offline candidates, over every output frame
// and run, relative to the codes' RMS displacement. Infinite when a rollout stopped.
double training_rollout_error(const Model& model, const Scene& scene, const RomSettings& settings,
                              const CubatureFit& fit);

// The greedy projection's set of settings.samples: selector's set at each of settings.selection_sensitivities, and of
// several the one with the lowest training_rollout_error (the first of equals; the first where the model holds no
// codes of the scene's training runs at its output times). log receives one line on the trials.
CubatureFit tried_projection_set(const Model& model, const Scene& scene, const RomSettings& settings,
                                 const ProjectionSelector& selector, bool fit,
                                 const std::function<void(const std::string&)>& log);

}  // namespace mpmrom::impl
