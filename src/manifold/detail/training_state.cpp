// The trainer's device state (manifold/detail/training_state.hpp): uploads, downloads and allocations only, no network
// kernels.
#include "manifold/detail/training_state.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace mpmrom::impl {
namespace {

using Vector = DeviceVector;
using Matrix = DeviceMatrix;
using Cube = DeviceCube;
using T = real_t;

// Every stride-th held-out point, at most 2048 of them.
std::vector<int> monitor_points_of(const std::vector<int>& validation_points) {
  std::vector<int> monitor_points;
  const std::size_t monitor_stride = std::max<std::size_t>(1, (validation_points.size() + 2047) / 2048);
  for (std::size_t i = 0; i < validation_points.size(); i += monitor_stride)
    monitor_points.push_back(validation_points[i]);
  return monitor_points;
}

// This rank's snapshots of one target (width values a point) as a device cube, filled through one host mirror of the
// build's precision: values(s, p) points at snapshot s's values at point p.
template <class Values>
Cube upload_snapshots(const std::string& label, const TrainingTargets& targets, const TrainingSizes& n, int width,
                      const Values& values) {
  Cube cube(label, n.num_owned, targets.points, width);
  auto host = Kokkos::create_mirror_view(cube);
  for (int i = 0; i < n.num_owned; ++i)
    for (std::size_t p = 0; p < targets.points; ++p) {
      const double* from = values(std::size_t(n.first_owned + i), p);
      for (int k = 0; k < width; ++k) host(i, p, k) = T(from[k]);
    }
  Kokkos::deep_copy(cube, host);
  return cube;
}

}  // namespace

TrainingSizes sizes_of(const Model& model, const TrainingSettings& settings, const PointSplit& points,
                       const parallel::Communicator& comm) {
  TrainingSizes n;
  n.S = int(model.code_time.size());
  if (n.S < comm.size())
    throw std::runtime_error(std::to_string(n.S) + " training snapshots cannot be shared by " +
                             std::to_string(comm.size()) + " processes");
  const auto share = parallel::share_of(std::size_t(n.S), comm.rank(), comm.size());
  n.first_owned = int(share.begin);
  n.num_owned = int(share.end - share.begin);
  n.num_weights = model.layout().num_params;
  n.num_total = n.num_weights + n.S * settings.latent_dim;
  n.per_snapshot = std::min<int>(settings.points_per_snapshot, int(points.training.size()));
  n.steps_per_epoch = (n.S + settings.batch_snapshots - 1) / settings.batch_snapshots;
  n.total_steps = long(n.steps_per_epoch) * settings.epochs;
  n.validate_every = settings.validate_every > 0 ? settings.validate_every : std::max(1, settings.epochs / 20);
  return n;
}

DeviceState upload_state(const Model& model, const OptimizerState& optimizer, const TrainingTargets& targets,
                         const TrainingSettings& settings, const TrainingSizes& n) {
  const int P = int(targets.points);
  DeviceState d;
  std::vector<double> all_params = model.weights;
  all_params.insert(all_params.end(), model.codes.begin(), model.codes.end());
  d.params = upload<Vector>("mpmrom::train::params", all_params, n.num_total);
  d.grad = Vector("mpmrom::train::grad", n.num_total);
  d.first_moment = upload<Vector>("mpmrom::train::adam_m", optimizer.first_moment, n.num_total);
  d.second_moment = upload<Vector>("mpmrom::train::adam_v", optimizer.second_moment, n.num_total);
  d.mlp = device_mlp(model, d.params);

  d.table.code_offset = n.num_weights;
  d.table.latent_dim = model.latent_dim;
  d.table.rate_from = upload_indices("mpmrom::train::rate_from", targets.stencil.from);
  d.table.rate_to = upload_indices("mpmrom::train::rate_to", targets.stencil.to);
  d.table.rate_inv_dt = upload<Vector>("mpmrom::train::rate_inv_dt", targets.stencil.inv_dt, n.S);

  d.batch.X = upload<Matrix>("mpmrom::train::X", targets.X, P, 3);
  d.batch.x = upload_snapshots("mpmrom::train::x", targets, n, 3,
                               [&](std::size_t s, std::size_t p) { return targets.x(s) + 3 * p; });
  d.batch.F = upload_snapshots("mpmrom::train::F", targets, n, 9,
                               [&](std::size_t s, std::size_t p) { return targets.F(s) + 9 * p; });
  d.batch.v = upload_snapshots("mpmrom::train::v", targets, n, 3,
                               [&](std::size_t s, std::size_t p) { return targets.v(s) + 3 * p; });
  if (targets.affine) {
    double CF[9];
    d.batch.CF = upload_snapshots("mpmrom::train::CF", targets, n, 9, [&](std::size_t s, std::size_t p) {
      targets.CF(s, p, CF);
      return static_cast<const double*>(CF);
    });
  }

  d.weights.lambda_gradient = T(settings.lambda_gradient);
  d.weights.lambda_velocity = T(settings.lambda_velocity);
  d.weights.lambda_affine = T(settings.lambda_affine);
  d.weights.affine_scale = T(model.loss_scales[3]);
  d.weights.position_scale = T(model.loss_scales[0]);
  d.weights.gradient_scale = T(model.loss_scales[1]);
  d.weights.velocity_scale = T(model.loss_scales[2]);
  d.channels =
      nn::Channels::make(settings.lambda_gradient > 0, settings.lambda_velocity > 0, settings.lambda_affine > 0);
  return d;
}

void download_state(const DeviceState& d, int num_weights, Model& model, OptimizerState& optimizer) {
  const auto p = download(d.params);
  model.weights.assign(p.begin(), p.begin() + num_weights);
  model.codes.assign(p.begin() + num_weights, p.end());
  optimizer.first_moment = download(d.first_moment);
  optimizer.second_moment = download(d.second_moment);
}

MinibatchStaging::MinibatchStaging(const nn::MlpLayout& layout, nn::Channels channels, const TrainingSettings& settings,
                                   int per_snapshot, const std::vector<int>& validation_points)
    : monitor_points(monitor_points_of(validation_points)),
      validation_group(std::max(1, 4096 / std::max(int(monitor_points.size()), 1))),
      batch_snapshots("mpmrom::train::batch_snapshot",
                      std::size_t(std::max(settings.batch_snapshots, validation_group))),
      batch_rows("mpmrom::train::batch_row", std::size_t(std::max(settings.batch_snapshots, validation_group))),
      batch_points("mpmrom::train::batch_point", std::max(std::size_t(settings.batch_snapshots) * per_snapshot,
                                                          std::size_t(validation_group) * monitor_points.size())),
      buffers(layout, channels) {}

}  // namespace mpmrom::impl
