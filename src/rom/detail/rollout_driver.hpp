// The reduced model's rollouts as their drivers see them, without the manifold's type: the scene's loads and reference
// solid, the hyper-reduction's sets, creating a batch stepper, running it to its horizon with checkpoints. The
// stepper itself is in rom_stepper.hpp. Private to the library and its tests.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/parallel.hpp"
#include "fom/fom.hpp"
#include "mpmrom/rom.hpp"
#include "rom/detail/batch_stepper_base.hpp"
#include "rom/kernels/loads.hpp"
#include "rom/kernels/reference_domain.hpp"

namespace mpmrom::impl {

// The full-order material points (row-major X (n, 3), mass and reference volume (n)) the reduced model stands for.
struct ReferencePoints {
  const std::vector<double>& X;
  const std::vector<double>& mass;
  const std::vector<double>& volume;
};

// One rollout's loads: forces as force per unit of the points' mass in each force region, as the full-order model
// shares them.
rom::RolloutLoads loads_for_scene(const Scene& scene, const ReferencePoints& points);
// The scene's bodies as the reference solid of Algorithm 2.
rom::ReferenceDomain reference_domain(const Scene& scene);
// Sets the scene's horizon to end_time rounded to whole output intervals, keeping the interval (--end-time).
void apply_horizon(Scene& scene, double end_time);

// Node set, neighbours and quadrature points for the samples, from positions (configurations, P, 3) of the motion
// the model covers. next[c], if given, is the configuration that follows c in time (-1 at a run's end): the sets then
// cover the straight path between the two, not just the output times.
HyperReduction hyper_reduction_from_motion(const Scene& scene, const RomSettings& settings,
                                           const std::vector<int>& samples, const std::vector<double>& positions,
                                           std::size_t P, const std::vector<int>& next = {});

// The batch of `cases` (values in the order of `names`) of the scene file at scene_path, on the model's network, at
// the scene's initial state projected onto the manifold. Throws std::runtime_error when the cases cannot share a
// batch or the model does not fit the scene.
std::unique_ptr<BatchStepperBase> create_stepper(const Model& model, const std::string& scene_path,
                                                 const std::vector<std::string>& names,
                                                 const std::vector<RolloutCase>& cases, const RomSettings& settings,
                                                 const HyperReduction& reduction);

// Runs the batch to its horizon, filling result's times, latent trajectories (every output frame), outcomes and
// step timing. With a checkpoint, the batch's state and the trajectories so far are saved there (atomically) at
// the first output frame after every checkpoint.seconds; with checkpoint.resume, a checkpoint left there by a run of
// the same batch is read first and the run goes on from it. With comm of several ranks (each stepper a share of one
// batch), the ranks checkpoint at the same frames, each into its own path, and resume from the latest frame they
// all saved.
void record_rollouts(BatchStepperBase& stepper, RomResult& result,
                     const std::function<void(const RomProgress&)>& progress, const RolloutCheckpoint& checkpoint = {},
                     const std::string& identity = "",
                     const parallel::Communicator& comm = parallel::Communicator::self());

// A rollout checkpoint (HDF5, written atomically): the batch's state and the trajectories recorded so far
// (result.xhat, result.xhatdot up to state.frame). load_rollout_checkpoint returns false when there is no file at
// path, and throws when the file is damaged or of another batch (identity).
void save_rollout_checkpoint(const std::string& path, const std::string& identity, const BatchState& state,
                             const RomResult& result);
bool load_rollout_checkpoint(const std::string& path, const std::string& identity, BatchState& state,
                             RomResult& result);

}  // namespace mpmrom::impl
