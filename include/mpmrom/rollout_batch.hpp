// The deployment API (docs/api.md): load a trained model, create a batch of reduced rollouts, advance it output
// interval by output interval, read each rollout's latent state and its decoded fields at any points.
//
//   mpmrom::KokkosSession kokkos;  // Kokkos must outlive every batch
//   const auto rom = mpmrom::ReducedModel::load("model.h5", "scenes/poke_cylinder.toml");
//   auto batch = rom.batch({{1.0, 5.0}, {1.2, 9.0}});  // one row of parameter values per rollout
//   while (batch.advance()) { ... batch.decode(0, points) ... }
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mpmrom/model.hpp"
#include "mpmrom/rom.hpp"
#include "mpmrom/scene.hpp"

namespace mpmrom {

namespace impl {
class BatchStepperBase;
}

// An array in the memory the batch's kernels run in (a GPU's in a CUDA build, the host's otherwise), described as
// DLPack describes one, so that PyTorch, CuPy, JAX or NumPy can take it without a copy. A snapshot: advancing the
// batch does not change it, and `owner` keeps its memory alive (release it before Kokkos is finalised).
struct DeviceArray {
  std::shared_ptr<const void> owner;
  const void* data = nullptr;
  std::vector<std::int64_t> shape;  // row-major, contiguous
  int bits = 64;                    // a float of 32 or 64 bits: the build's precision (mpmrom_config.hpp)
  int dlpack_device_type = 1;       // DLPack's DLDeviceType: 1 the host (kDLCPU), 2 a CUDA GPU (kDLCUDA)
  int device_id = 0;
};

// Rollouts of one model sharing a scene's grid, material and output times; each has its own parameter values
// (loads, boundary values). Works on Kokkos' default execution space; not thread-safe.
class RolloutBatch {
 public:
  // The cases (values in the order of `names`, parameters of the scene file at scene_path) at the scene's initial
  // state projected onto the manifold. Throws std::runtime_error when the cases change the grid, material or initial
  // velocity, or the model does not fit the scene.
  RolloutBatch(const Model& model, const std::string& scene_path, const std::vector<std::string>& names,
               const std::vector<RolloutCase>& cases, const RomSettings& settings, const HyperReduction& reduction);
  ~RolloutBatch();
  RolloutBatch(RolloutBatch&&) noexcept;
  RolloutBatch& operator=(RolloutBatch&&) noexcept;

  int size() const;        // rollouts
  int latent_dim() const;  // r
  int frame() const;       // output frame reached: 0 (the initial state) to frames() - 1
  int frames() const;
  double time() const;                       // of frame()
  const std::vector<double>& times() const;  // every output time, frames() of them
  long steps() const;                        // time steps taken so far (each advances every rollout)

  // Advances every running rollout to the next output time (a stopped rollout keeps its last state); false, doing
  // nothing, at the horizon.
  bool advance();
  // The latent state xhat and its rate now: (size(), r) row-major each.
  std::vector<double> latent_state() const;
  std::vector<double> latent_rate() const;
  // Flags, stop time and message, counters, and a warning for parameters outside the model's training range.
  std::vector<RolloutOutcome> outcomes() const;
  bool running(int rollout) const;  // false once a detector has stopped it (docs/stability.md)
  // Rollout `rollout`'s fields now at reference points X (n, 3) row-major: x and v (n, 3), F (n, 3, 3).
  DecodedFields decode(int rollout, const std::vector<double>& X) const;
  // Every rollout's fields now at the same reference points, in one pass of the network over the batch: x and v
  // (size(), n, 3), F (size(), n, 3, 3). A stopped rollout's fields are those of its last state.
  DecodedFields decode_all(const std::vector<double>& X) const;
  // xhat and xhatdot now, (size(), r), left in the device's memory (no copy to the host).
  DeviceArray latent_state_on_device() const;
  DeviceArray latent_rate_on_device() const;

 private:
  friend class ReducedModel;
  RolloutBatch(std::shared_ptr<const Model> model, const std::string& scene_path, const std::vector<std::string>& names,
               const std::vector<RolloutCase>& cases, const RomSettings& settings, const HyperReduction& reduction);

  std::shared_ptr<const Model> model_;
  std::vector<std::string> names_;
  std::vector<RolloutCase> cases_;
  std::unique_ptr<impl::BatchStepperBase> stepper_;
};

// A trained model ready to run on a scene: the model, the scene, the reduced model's settings and its precomputed
// sets (sample points, node set).
class ReducedModel {
 public:
  // Loads the model file and the scene file, and selects sample points with settings.selection (greedy from the
  // model's stored ranking, region or random; for a greedy selection refitted to other runs, build the sets with
  // select_samples and build_hyper_reduction).
  static ReducedModel load(const std::string& model_path, const std::string& scene_path, RomSettings settings = {});

  const Model& model() const { return *model_; }
  const Scene& scene() const { return scene_; }
  const RomSettings& settings() const { return settings_; }
  const HyperReduction& hyper_reduction() const { return reduction_; }
  // The parameters a rollout sets, in order: the scene's [design] names, or all its parameters.
  const std::vector<std::string>& parameter_names() const { return names_; }
  // The reference points of the model (the full-order material points), (n, 3) row-major: decode them to see the body.
  const std::vector<double>& reference_points() const { return model_->X; }

  // One rollout per row of parameter values (in parameter_names() order).
  RolloutBatch batch(const std::vector<std::vector<double>>& parameter_values) const;

 private:
  std::shared_ptr<const Model> model_;
  Scene scene_;
  std::string scene_path_;
  RomSettings settings_;
  HyperReduction reduction_;
  std::vector<std::string> names_;
};

}  // namespace mpmrom
