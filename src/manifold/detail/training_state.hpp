// The trainer's device state (manifold/trainer.cpp, which alone runs the training kernels on it): the sizes a
// training run shares, its parameters and targets on the device, and the minibatch index lists and buffers.
#pragma once

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/parallel.hpp"
#include "manifold/detail/training_host.hpp"
#include "manifold/device_data.hpp"
#include "manifold/nn/mlp_train.hpp"
#include "mpmrom/model.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom::impl {

// Index lists sent to the device every minibatch, through one allocation made up front (a device allocation per
// step would cost more than the step on a GPU).
class IndexStaging {
 public:
  IndexStaging(const std::string& label, std::size_t capacity)
      : device_(label, capacity), host_(Kokkos::create_mirror_view(device_)) {}
  Kokkos::View<const int*, DeviceMemory> upload(const std::vector<int>& values) {
    if (values.size() > device_.extent(0)) throw std::logic_error("IndexStaging: more indices than its capacity");
    std::copy(values.begin(), values.end(), host_.data());
    const auto range = Kokkos::make_pair(std::size_t(0), values.size());
    Kokkos::deep_copy(Kokkos::subview(device_, range), Kokkos::subview(host_, range));
    return Kokkos::subview(device_, range);
  }

 private:
  Kokkos::View<int*, DeviceMemory> device_;
  Kokkos::View<int*, DeviceMemory>::HostMirror host_;
};

// Data-parallel training: the ranks' minibatch gradients summed in place, through a host copy (the gradient is a
// few thousand values, one MPI_Allreduce a step).
class GradientSum {
 public:
  explicit GradientSum(const DeviceVector& grad) : host_(Kokkos::create_mirror_view(grad)) {}
  void sum(const Kokkos::DefaultExecutionSpace& space, const DeviceVector& grad, const parallel::Communicator& comm) {
    Kokkos::deep_copy(space, host_, grad);
    space.fence();
    comm.sum(host_.data(), host_.size());
    Kokkos::deep_copy(space, grad, host_);
  }

 private:
  DeviceVector::HostMirror host_;
};

inline void sum_over_ranks(const parallel::Communicator& comm, nn::LossTerms<double>& terms) {
  double values[4] = {terms.position, terms.gradient, terms.velocity, terms.affine};
  comm.sum(values, 4);
  terms = {values[0], values[1], values[2], values[3]};
}

// Device buffers of one minibatch shape, created on first use.
class BufferCache {
 public:
  BufferCache(const nn::MlpLayout& layout, nn::Channels channels) : layout_(layout), channels_(channels) {}
  nn::TrainingBuffers<real_t, DeviceMemory>& get(int batch_snapshots, int per_snapshot) {
    auto& slot = cache_[{batch_snapshots, per_snapshot}];
    if (!slot)
      slot = std::make_unique<nn::TrainingBuffers<real_t, DeviceMemory>>(
          Kokkos::DefaultExecutionSpace(), layout_, channels_, batch_snapshots * per_snapshot, batch_snapshots);
    return *slot;
  }

 private:
  nn::MlpLayout layout_;
  nn::Channels channels_;
  std::map<std::pair<int, int>, std::unique_ptr<nn::TrainingBuffers<real_t, DeviceMemory>>> cache_;
};

// The sizes the steps of one training run share. Data-parallel training: this rank's device holds the targets of its
// share of the snapshots (every rank holds every weight and code), works on the samples of each minibatch that fall
// in its share, and the ranks sum their gradients before the identical Adam steps.
struct TrainingSizes {
  int S = 0, first_owned = 0, num_owned = 0;  // training snapshots, and this rank's share of them
  int num_weights = 0, num_total = 0;         // parameters: the weights, then the codes
  int per_snapshot = 0, steps_per_epoch = 0, validate_every = 0;
  long total_steps = 0;
};

// Throws if there are fewer training snapshots than ranks.
TrainingSizes sizes_of(const Model& model, const TrainingSettings& settings, const PointSplit& points,
                       const parallel::Communicator& comm);

// The device side of one training run: parameters (weights, then codes), their gradient and Adam moments, the network
// over them, the codes' rate stencil, this rank's targets, and the loss weights.
struct DeviceState {
  Kokkos::DefaultExecutionSpace space;
  DeviceVector params, grad, first_moment, second_moment;
  nn::Mlp<real_t, DeviceMemory> mlp;
  nn::CodeTable<real_t, DeviceMemory> table;
  nn::BatchSamples<real_t, DeviceMemory> batch;
  nn::LossWeights<real_t> weights;
  nn::Channels channels;
};

// Uploads the model's parameters, the optimizer's moments and this rank's share of the targets.
DeviceState upload_state(const Model& model, const OptimizerState& optimizer, const TrainingTargets& targets,
                         const TrainingSettings& settings, const TrainingSizes& n);

// Host-side copies of the device state, for checkpoints and the final model.
void download_state(const DeviceState& d, int num_weights, Model& model, OptimizerState& optimizer);

// The index lists of the minibatches (and of the validation loss's groups of snapshots) on the device, and the
// training buffers of each minibatch shape. The loss reported during training uses at most 2048 of the held-out
// points, evenly spread (monitor_points): on 10^6-point scenes every held-out point at every snapshot would cost more
// than the training itself. The final errors use them all.
struct MinibatchStaging {
  MinibatchStaging(const nn::MlpLayout& layout, nn::Channels channels, const TrainingSettings& settings,
                   int per_snapshot, const std::vector<int>& validation_points);

  std::vector<int> monitor_points;
  int validation_group;  // snapshots per validation loss evaluation
  IndexStaging batch_snapshots, batch_rows, batch_points;
  BufferCache buffers;
};

}  // namespace mpmrom::impl
