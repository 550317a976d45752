// Training the deformation map (paper, equation 7) as an auto-decoder: one latent code per training snapshot,
// trained jointly with the network's weights by Adam on minibatches of (snapshot, material point) samples, on the
// default Kokkos execution space. Also the projection of new snapshots onto a trained manifold, and the errors of
// the reconstruction.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "snapshots/metrics.hpp"
#include "mpmrom/model.hpp"
#include "core/parallel.hpp"
#include "mpmrom/training_data.hpp"

namespace mpmrom {

struct TrainingSettings {
  int latent_dim = 5;                 // r
  int width = 48;                     // hidden units per layer
  int depth = 5;                      // affine layers (the paper's 5 layers)
  double lambda_gradient = 1.0;       // lambda1: weight of the F = dg/dX misfit, relative
  double lambda_velocity = 1.0;       // lambda2: weight of the dg/dxhat * xhatdot misfit, relative
  double lambda_affine = 0.0;         // lambda3: weight of the Fdot - C F misfit (APIC's C), relative; not the paper's
  int epochs = 600;                   // each visits every training snapshot once
  int batch_snapshots = 8;            // snapshots per minibatch
  int points_per_snapshot = 128;      // material points drawn per snapshot visit
  int max_points = 0;                 // material points the training runs are read at (a random subset); 0: all
  double learning_rate = 3e-3;        // Adam, first epoch
  double final_learning_rate = 3e-5;  // Adam, last epoch (exponential decay in between)
  double validation_fraction = 0.1;   // material points held out of training, to watch over-fitting
  int validate_every = 0;             // epochs between validation losses (0: about 20 per run)
  std::uint64_t seed = 1;
  double checkpoint_seconds = 60;  // wall-clock time between checkpoints

  nlohmann::json to_json() const;
  static TrainingSettings from_json(const nlohmann::json& json);
  void validate() const;  // throws std::invalid_argument naming the bad setting
};

// What training reads of each run: APIC's C only when the affine term needs it (3/8 of a run's file).
inline SnapshotFields training_fields(const TrainingSettings& settings) {
  return settings.lambda_affine > 0 ? SnapshotFields::All : SnapshotFields::WithoutAffine;
}

struct LossReport {
  double total = 0, position = 0, gradient = 0, velocity = 0, affine = 0;  // mean relative terms, total with lambdas
};

struct TrainingProgress {
  int epoch = 0;  // finished epochs
  int epochs = 0;
  LossReport train;
  bool validated = false;
  LossReport validation;
  double learning_rate = 0;
  double samples_per_second = 0;
  double seconds = 0;  // wall-clock time of this process's training so far
  double seconds_left = 0;
};

struct TrainingCallbacks {
  std::function<void(const TrainingProgress&)> progress;
  std::function<void(const std::string&)> message;  // one-line notes (resuming, checkpoint written, ...)
};

// Trains a model on data.train and reports its errors: on the training snapshots (all points, and the held-out
// validation points alone) and, if data.test is not empty, on the test runs with codes fitted by projection. If
// checkpoint_path is not empty, the state is saved there every settings.checkpoint_seconds; with resume, training
// continues from that checkpoint (which must come from the same settings and data).
// Under MPI (comm of several ranks; docs/mpi.md) the training is data-parallel: each rank holds a share of the
// snapshots' targets on its device and the ranks sum their minibatch gradients, so the result matches one process's
// within round-off; rank 0 writes the checkpoints and alone evaluates the errors (the other ranks return the model
// without them).
Model train_model(const TrainingData& data, const TrainingSettings& settings, const std::string& checkpoint_path,
                  bool resume, const TrainingCallbacks& callbacks = {},
                  const parallel::Communicator& comm = parallel::Communicator::self());

// Latent codes (frames, r) that best reproduce each frame's positions: Levenberg-Marquardt on the sum of squared
// position misfits over all points, started from the closest training code.
std::vector<double> project_codes(const Model& model, const Snapshot& run);

// The reconstruction's velocity frame by frame: squared misfits summed over the run's points, of the codes' finite-
// difference rates and of the best rate on the tangent space (the least-squares fit of the run's velocities, the
// least velocity error any reduced dynamics on this manifold can reach at the frame's code), and |v|^2.
struct VelocityByFrame {
  std::vector<double> time, rate_misfit, tangent_misfit, norm;

  // The error over every frame of the best rates (SPEC's velocity_error with the tangent fit's velocities).
  double tangent_velocity_error() const;
  // Per frame: {"time", "velocity_error", "tangent_velocity_error"}.
  nlohmann::json frames_json() const;
};

struct ReconstructionErrors {
  ErrorAccumulator errors;
  VelocityByFrame velocity;  // of every point; empty when `points` chose some
};

// Errors of the model with the given codes (frames, r) against the run; velocities from the codes' finite
// differences in time. points: the material points to include (empty: all).
ReconstructionErrors reconstruction_errors(const Model& model, const Snapshot& run, const std::vector<double>& codes,
                                           const std::vector<int>& points = {});

}  // namespace mpmrom
