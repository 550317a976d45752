// The reduced model's batch stepper as its drivers see it (the time stepper's state, checkpoints, outcomes),
// independent of the manifold's type; src/rom/detail/rom_stepper.hpp implements it. Private to the library and its
// tests.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "mpmrom/rollout_batch.hpp"
#include "rom/outcome.hpp"

namespace mpmrom::impl {

// Everything a batch's future depends on, at an output frame: what a rollout checkpoint holds.
struct BatchState {
  int frame = 0;
  long steps = 0;
  double step_seconds = 0, max_speed = 0;
  std::vector<double> xhat, xhatdot, max_condition;          // (rollouts, r), (rollouts, r), (rollouts)
  std::vector<int> flags, failures, fallbacks, regularized;  // (rollouts)
  std::vector<double> reference;                             // Algorithm 2 warm starts: (rollouts, sources, 3)
  std::vector<int> converged;                                //   and whether each converged (rollouts, sources)
  std::vector<RolloutOutcome> outcomes;                      // frames completed, stop time and message
};

// A batch of rollouts on the device and the step that advances it, one output interval at a time. The base class
// hides the manifold's type, so that the public RolloutBatch (rollout_batch.hpp) can hold any network width.
class BatchStepperBase {
 public:
  virtual ~BatchStepperBase() = default;
  int rollouts() const { return int(outcomes_.size()); }
  int latent_dim() const { return latent_dim_; }
  int frames() const { return int(times_.size()); }  // output frames, the initial state included
  int frame() const { return frame_; }               // the output frame the batch is at
  double time() const { return times_[std::size_t(frame_)]; }
  const std::vector<double>& times() const { return times_; }
  long steps() const { return steps_; }
  double step_seconds() const { return step_seconds_; }  // wall time spent in advance_frame
  // The points at which a sub-step evaluates the network for each rollout: Algorithm 1's sources (the samples and
  // their neighbours), Algorithm 2's samples and quadrature points, the Galerkin step's samples and the nodes of its
  // grid strain's stencils. What a step's cost grows with (issue 29's evaluated_points).
  std::size_t evaluated_points() const { return evaluated_points_; }
  // Advances every running rollout to the next output time (rollouts that have stopped keep their last state);
  // false, doing nothing, when the batch is already at the horizon.
  virtual bool advance_frame() = 0;
  // One sub-step of the current output interval's time step from the current state, leaving the frame, the step
  // count and the outcomes as they were: the offline fits' snapshots of one step from given states (rom/cubature.cpp).
  // Returns the sub-step's time step (0: none, at the horizon).
  virtual double probe_substep() = 0;
  // One sub-step from the current state and back to it, the batch's state unchanged: the step's kernels take their
  // first launches here, in the set-up, rather than in the first frame's step time (a rollout's set-up calls it).
  virtual void warm_up() = 0;
  // The latent state and its rate now, (rollouts, r) row-major each.
  virtual void latent(std::vector<double>& xhat, std::vector<double>& xhatdot) const = 0;
  // The same for one rollout (r values each): copies that rollout's row only.
  virtual void latent_of(int rollout, std::vector<double>& xhat, std::vector<double>& xhatdot) const = 0;
  // A device copy of the latent state (rate: its rate), (rollouts, r).
  virtual DeviceArray latent_on_device(bool rate) const = 0;
  // The rollout's detector flags as of the last output frame, kept on the host (no device copy).
  int flags(int rollout) const { return outcomes_[std::size_t(rollout)].flags; }
  // What has happened to each rollout so far: flags, stop time and message, counters, frames completed.
  virtual std::vector<RolloutOutcome> outcomes() const = 0;
  // The batch's state now, and back to a saved one (of a batch of the same model, scene, settings and rollouts):
  // advancing from a restored state repeats bit for bit what the saved batch did next.
  virtual BatchState state() const = 0;
  virtual void restore(const BatchState& state) = 0;
  // The last sub-step's projection inputs, for the cubature fitted to the reduced motion (rom/cubature.cpp): dg/dxhat
  // at the samples as the final pass evaluated it (rollouts, samples, 3, r), the samples' transferred velocities
  // (rollouts, samples, 3), each rollout's rate before that sub-step (rollouts, r) and, for the Galerkin step, the
  // samples' reduced forces per unit mass (rollouts, samples * r; empty otherwise).
  struct ProjectionInputs {
    std::vector<double> J, velocity, rate_before, force;
  };
  virtual ProjectionInputs last_projection_inputs() const = 0;
  // Under MPI, ranks holding shares of one batch advance it with one time step, as one process would: combine
  // replaces each value by its maximum over the ranks (empty: this stepper holds the whole batch).
  void share_time_step(std::function<void(double*, std::size_t)> combine) { share_max_ = std::move(combine); }

 protected:
  BatchStepperBase(int rollouts, int latent_dim, std::vector<double> times)
      : latent_dim_(latent_dim), times_(std::move(times)), outcomes_(std::size_t(rollouts)) {
    for (auto& outcome : outcomes_) outcome.frames_completed = 1;
  }
  int latent_dim_;
  std::vector<double> times_;
  int frame_ = 0;
  long steps_ = 0;
  double step_seconds_ = 0;
  std::size_t evaluated_points_ = 0;
  std::vector<RolloutOutcome> outcomes_;  // flags, frames_completed, stopped_at and message, kept on the host
  std::function<void(double*, std::size_t)> share_max_;
};

}  // namespace mpmrom::impl
