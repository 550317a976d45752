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

// The training snapshots, run after run, frame after frame: their targets (points, 3 or 9 values per snapshot), read
// in place from the runs (a 10^6-point sweep holds tens of GB, a copy would double it), and the stencil of their code
// rates. The runs must outlive it.
struct TrainingTargets {
  RateStencil stencil;
  std::size_t points = 0;
  std::vector<double> X;  // (points, 3): the trained points' reference positions (all of the model's, or a subset)
  bool affine = false;    // lambda3 > 0: the affine term's C F, made from the runs' C and F where it is read

  struct Frame {
    const Snapshot* run;
    std::size_t frame;
  };
  std::vector<Frame> snapshots;

  std::size_t size() const { return snapshots.size(); }
  const double* x(std::size_t s) const { return field(snapshots[s].run->x, s, 3); }
  const double* F(std::size_t s) const { return field(snapshots[s].run->F, s, 9); }
  const double* v(std::size_t s) const { return field(snapshots[s].run->v, s, 3); }
  // C F of point p of snapshot s (row-major 3 x 3), the rate of F that the affine term asks Fdot to match.
  void CF(std::size_t s, std::size_t p, double out[9]) const;

 private:
  const double* field(const std::vector<double>& values, std::size_t s, std::size_t width) const {
    return values.data() + snapshots[s].frame * points * width;
  }
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
