// The host-side steps of train_model (manifold/trainer.cpp): the model's targets, scales and initial parameters, the
// split of the material points, resuming from a checkpoint, and the trained model's errors.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/timing.hpp"
#include "manifold/detail/rate_stencil.hpp"
#include "manifold/trainer.hpp"
#include "mpmrom/model.hpp"
#include "mpmrom/training_data.hpp"

namespace mpmrom::impl {

// The training snapshots, run after run, frame after frame: their targets (points, 3 or 9 values per snapshot) and
// the stencil of their code rates.
struct TrainingTargets {
  RateStencil stencil;
  std::vector<double> x, F, v, CF;  // CF: C F with APIC's C, only for lambda3 > 0
};

// Material points held out of training (to watch over-fitting) and those trained on, each sorted.
struct PointSplit {
  std::vector<int> validation, training;
};

// callbacks.message(text), if set.
inline void say(const TrainingCallbacks& callbacks, const std::string& text) {
  if (callbacks.message) callbacks.message(text);
}

// splitmix64 of (seed, epoch): independent streams per epoch, so a resumed run draws what the original would have.
std::uint64_t epoch_seed(std::uint64_t seed, std::uint64_t epoch);

// A model of data.train's reference configuration, snapshots and settings, without scales or parameters; targets
// receives the snapshots' targets and rate stencil.
Model start_model(const TrainingData& data, const TrainingSettings& settings, TrainingTargets& targets);

// A seeded random fraction (settings.validation_fraction) of the P material points held out.
PointSplit split_points(const TrainingSettings& settings, int P);

// The model's standardisation and loss scales from the training points of every training snapshot.
void set_scales(Model& model, const TrainingTargets& targets, const std::vector<int>& training_points);

// Initial weights (LeCun-uniform, zero biases) and codes (leading principal coordinates of the displacements).
void set_initial_parameters(Model& model, const TrainingSettings& settings, const TrainingTargets& targets,
                            const std::vector<int>& training_points);

// The parameters, scales and optimizer state of the checkpoint, which must come from the same settings and runs.
void resume_from(const std::string& checkpoint_path, Model& model, OptimizerState& optimizer);

// model.errors of the trained model: every training snapshot with its own code (all points, and the validation points
// alone) and the test runs with projected codes; final: the last epoch's progress, start: training's start.
void set_errors(Model& model, const TrainingData& data, const std::vector<int>& validation_points,
                const TrainingProgress& final, SteadyClock::time_point start, const TrainingCallbacks& callbacks);

}  // namespace mpmrom::impl
