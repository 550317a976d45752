// The reduced-order model (paper, "Dynamics: velocity projection"): a batch of rollouts, each with its own parameter
// values, advanced together on the default Kokkos execution space with Algorithm 1 (material-point-centric) or
// Algorithm 2 (sample-node-centric), with hyper-reduction (a few sample points) or without (all points).
// docs/rom.md describes the method, the precomputed sets and the failure policies.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mpmrom/model.hpp"
#include "mpmrom/scene.hpp"
#include "mpmrom/training_data.hpp"

namespace mpmrom {
namespace parallel {
class Communicator;
}

// Algorithm 1, Algorithm 2, and the reduced equations of motion by cubature without a grid (docs/rom.md "Galerkin").
enum class RomMethod { MaterialPoint, SampleNode, Galerkin };
enum class SampleSelection { Region, Random, Greedy, Cubature, GreedyProjection };
// After the grid update: fit the samples' velocities in the tangent space and integrate them (the paper's), or also
// move the latent state onto the samples' updated positions by Gauss-Newton (docs/rom.md "Projection").
enum class ProjectionScheme { Velocity, Position };
// Where the offline fits' snapshots come from: the all-point reduced model rolled out over the scene's training
// design (Reduced), one all-point sub-step from each of the model's training states (States), or the full-order
// training runs (Full).
enum class SnapshotSource { Reduced, States, Full };
SnapshotSource snapshot_source_from_string(const std::string& name);  // "reduced", "states" or "full"
std::string to_string(SnapshotSource source);

// What the Galerkin step's cubature weights reproduce over the snapshots: its own all-point reduced force (Own), or
// the grid step's, Algorithm 1 with every point (Grid): the samples' continuum forces then stand in for MPM's.
enum class CubatureTarget { Own, Grid };
CubatureTarget cubature_target_from_string(const std::string& name);  // "own" or "grid"
std::string to_string(CubatureTarget target);

// The deformation gradient the Galerkin step's energy is taken at: the manifold's own, dg/dX at each sample
// (Continuum), or MPM's, the gradient of the displacements of the grid nodes around the sample in the reference
// configuration with the quadratic B-splines (Grid; docs/rom.md "Galerkin step").
enum class GalerkinStrain { Continuum, Grid };
GalerkinStrain galerkin_strain_from_string(const std::string& name);  // "continuum" or "grid"
std::string to_string(GalerkinStrain strain);

// The Galerkin step's time integrator: symplectic Euler (the force at the step's start, then the rate, then the
// position: first order) or leapfrog (half a step's drift, the force there, the kick, the other half's drift: second
// order for the same one force a step; docs/rom.md "Time step"). The grid methods step as the grid does.
enum class TimeIntegrator { SymplecticEuler, Leapfrog };
TimeIntegrator time_integrator_from_string(const std::string& name);  // "euler" or "leapfrog"
std::string to_string(TimeIntegrator integrator);

// The samples' weights in the projection: their masses, empirical cubature weights fitted to snapshots, or (Auto) the
// weights the selection fits with its samples (greedy projection, cubature) and the masses otherwise.
enum class SampleWeighting { Mass, Cubature, Auto };

RomMethod rom_method_from_string(const std::string& name);  // "point", "node" or "galerkin"
std::string to_string(RomMethod method);
SampleSelection sample_selection_from_string(const std::string& name);  // "region", "random", "greedy", "cubature"
std::string to_string(SampleSelection selection);
ProjectionScheme projection_scheme_from_string(const std::string& name);  // "velocity" or "position"
std::string to_string(ProjectionScheme scheme);
SampleWeighting sample_weighting_from_string(const std::string& name);  // "mass", "cubature" or "auto"
std::string to_string(SampleWeighting weighting);

struct RomSettings {
  RomMethod method = RomMethod::MaterialPoint;
  int samples = 15;  // sample material points; 0: every point (no hyper-reduction)
  // Greedy on the projection with its fitted weights: the lowest measured error (docs/rom.md "Defaults"); the
  // model's stored set when it holds one of this count (Model::projection_samples).
  SampleSelection selection = SampleSelection::GreedyProjection;
  // The greedy projection's trial sets: one for each weight of the samples' response to the latent state (how a
  // training state's increments change along each latent coordinate) against the increments' own; with several, the
  // set whose rollouts over the training runs stay closest to the model's codes (docs/rom.md "Sample selection").
  // The greedy error alone does not tell which set holds the motion: a set that fits the increments but not their
  // response can give the reduced stiffness a wrong sign and blow up.
  std::vector<double> selection_sensitivities = {0, 0.1, 0.3, 1};
  std::uint64_t seed = 1;         // random selection
  double cfl = 0;                 // time step = cfl dx / (wave speed + fastest sample); 0: the scene's cfl
  double envelope_margin = 0.25;  // cells of slack around the training motion when building the node set
  // Algorithm 2: Gauss points per axis in each dual cell (1-3). 3: with every point as a sample, 2 x 2 x 2 leave
  // 0.72 % position error on the poke cylinder, 3 x 3 x 3 0.17 % (docs/results/rom/README.md "Algorithm 2's floor").
  int quadrature_order = 3;
  double newton_tolerance = 1e-4;  // Algorithm 2: inversion residual, in cells
  int newton_iterations = 20;
  // Re-projections with dg/dxhat at the trial next state (0: the paper's dg/dxhat at xhat(t_n) only).
  int projection_iterations = 2;
  ProjectionScheme projection = ProjectionScheme::Velocity;  // "position" acts in the re-projections
  // Tikhonov weight toward the previous rate, relative to the mean eigenvalue of the weighted normal matrix (0: none).
  double rate_damping = 0;
  SampleWeighting weighting = SampleWeighting::Auto;
  // What the cubature and the greedy projection selection fit (--cubature-snapshots, docs/rom.md "Sample weights").
  SnapshotSource snapshot_source = SnapshotSource::Reduced;
  // The offline fits' candidate points on a larger body (every point on a smaller one): more fit the all-point sums
  // better, at a set-up cost that grows with their square (the fits' normal equations).
  int cubature_candidates = 2048;
  // The training runs the offline fits probe (or roll out), spread over the design, and with --cubature-snapshots
  // states the inner output frames of each they probe: more states generalise the fits to other parameters, at a
  // set-up cost linear in their number (docs/rom.md "Sample weights").
  int cubature_runs = 8;
  int cubature_frames = 8;
  CubatureTarget cubature_target = CubatureTarget::Own;        // --method galerkin's weights (--cubature-target)
  GalerkinStrain galerkin_strain = GalerkinStrain::Continuum;  // --method galerkin's energy (--galerkin-strain)
  // With the grid strain: the momentum carried through the stencil's nodes as MPM's transfer carries it.
  bool galerkin_transfer = false;
  // With the grid strain: each stencil node's test function (the virtual velocity its stress and load work against)
  // is dg/dxhat at the mass centroid of the material it receives, as G2P and the projection average the grid's
  // change over a node's particles, instead of at the node itself.
  bool galerkin_node_average = false;
  TimeIntegrator integrator = TimeIntegrator::SymplecticEuler;  // --method galerkin's (--integrator)
  double max_condition = 0;   // regularise the normal equations above this estimate (0: 0.01 / epsilon)
  double regularization = 0;  // mu = regularization * trace / r (0: 100 epsilon)
  // Safeguards and detectors (docs/stability.md).
  bool regularize = true;               // false: an ill-conditioned projection stops the rollout instead
  bool inversion_fallback = true;       // Algorithm 2: retry a failed inversion cold, then reuse last step's solution
  double max_failed_inversions = 0.05;  // Algorithm 2: stop when more than this fraction fails in one step
  double energy_growth = 10;  // stop when |xhatdot| exceeds this times the fastest training motion (0: no check)
  // Horizon (s), rounded to a whole number of the scene's output intervals (0: the scene's end time).
  double end_time = 0;

  nlohmann::json to_json() const;
  void validate() const;  // throws std::invalid_argument naming the bad setting
};

// The defaults of `method` (docs/rom.md "Defaults"): RomSettings{} for Algorithms 1 and 2; for the Galerkin step its
// best measured configuration, MPM's strain with the cubature selection fitted to the grid step's force over the
// training states, stepped by the leapfrog (the greedy projection fits the grid step of the other two).
RomSettings rom_defaults(RomMethod method);

// The weighting settings.weighting stands for: Auto resolved (Cubature for the greedy projection and cubature
// selections of some samples, Mass otherwise), the others as they are.
SampleWeighting fitted_weights(const RomSettings& settings);

// The precomputed sets of a hyper-reduced model (from the training motion the model reproduces).
struct HyperReduction {
  std::vector<int> samples;  // M: indices into the model's reference points
  // The projection's weight of each sample (cubature_weights); empty: the samples' masses.
  std::vector<double> weights;
  // The Galerkin step's weight of each sample's force where it differs from `weights` (CubatureFit::force_weights);
  // empty: `weights`.
  std::vector<double> force_weights;
  // The cubature fit's relative misfits over its snapshots (the normal matrix, then each projected field; the
  // Galerkin step's force last) where the weights were fitted here; empty otherwise.
  std::vector<double> weight_misfits;
  // The same over a training run held out of the fit (CubatureFit::held_out_misfits); empty: none.
  std::vector<double> weight_misfits_held_out;
  // The Galerkin step's bound on the time step from its reduced dynamics, 1 / omega for the highest frequency omega
  // over the training states (docs/rom.md "Time step"); 0: none (the CFL number alone sets the step).
  double stable_time_step = 0;
  // Algorithm 1: the material points feeding the transfer, samples first (M, then the neighbours N).
  std::vector<int> source_points;
  // Algorithm 2: quadrature points (current configuration) and their volume weights.
  std::vector<double> quadrature_x, quadrature_weight;
  // I: grid nodes (global indices) and, per node, the sources (indices into source_points or the quadrature points)
  // that can reach it: node n gathers node_sources[node_offsets[n] .. node_offsets[n + 1]).
  std::vector<int> nodes, node_offsets, node_sources;

  std::size_t num_sources() const { return node_offsets.empty() ? 0 : source_points.size() + quadrature_weight.size(); }
  nlohmann::json summary() const;
};

// Picks settings.samples material points (all of them when 0). Greedy selection fits the full-order training runs'
// velocities: from data when given, else the model's stored ranking (Model::sample_ranking); the other rules need
// only the model and the scene.
std::vector<int> select_samples(const Model& model, const Scene& scene, const RomSettings& settings,
                                const TrainingData* data);

// How many sample points a trained model ranks (Model::sample_ranking): more than any measured configuration uses.
inline constexpr std::size_t ranked_samples = 64;

// The first `count` points of the greedy selection on the model's training runs (data), in the order chosen: its
// first k entries are the greedy selection of k. Stored with the model by `mpmrom train` and the pipeline.
std::vector<std::int64_t> rank_samples_greedily(const Model& model, const TrainingData& data, std::size_t count);

// Empirical cubature of the projection (docs/rom.md "Sample weights"): non-negative weights w_s (units of mass) with
// which the samples' sums of J_s^T J_s and of J_s^T (field) best reproduce the all-point sums sum_p m_p (...) over
// snapshots, each block as a relative least-squares misfit. The snapshots (their J and fields) come from
// - data: the full-order training runs (J at about `count` of the model's codes; fields: the runs' velocities and
//   their accelerations by central differences of the frames), kept alive by the caller; or
// - scene_path: the all-point reduced model (with `settings`) rolled out over at most `count` runs of the scene's
//   training design (J of each output frame's last sub-step and the velocity that sub-step added; with
//   settings.method Galerkin, the Galerkin step's momentum J^T v and each point's reduced force).
struct CubatureSnapshots {
  const TrainingData* data = nullptr;
  std::string scene_path;
  RomSettings settings;
  std::size_t count = 48;
  // The offline selections' candidates: every point, or this many spread evenly over a larger body; there the
  // training-state snapshots hold the candidates alone (their mass-weighted sums a quadrature of the all-point ones).
  std::size_t max_candidates = 2048;
};
struct CubatureFit {
  std::vector<int> samples;
  std::vector<double> weights;
  std::vector<double> misfits;  // relative, per block: the normal matrix, then each field
  // The same over one training run's snapshots of weights fitted without them (empty: the snapshots hold one run).
  std::vector<double> held_out_misfits;
  // The Galerkin step's force weights where they are fitted apart from the mass and momentum weights above
  // (CubatureTarget::Grid: the grid step's force is not the samples' own); empty: the same weights.
  std::vector<double> force_weights;
};
// The snapshots settings.cubature_from_reduced_motion asks for: the reduced model on the scene (its source_path), or
// data's training runs (throws std::invalid_argument when data is null).
CubatureSnapshots cubature_snapshots(const Scene& scene, const RomSettings& settings, const TrainingData* data);
// Weights for the given samples (a weight may be 0).
CubatureFit cubature_weights(const Model& model, const CubatureSnapshots& snapshots, const std::vector<int>& samples);
// Samples and weights together: the points Lawson and Hanson's active set takes, up to count (ECSW's selection),
// among every point (max_candidates spread evenly over a larger body).
CubatureFit cubature_selection(const Model& model, const CubatureSnapshots& snapshots, std::size_t count);
// Greedy on the projection (docs/rom.md "Sample selection"): adds, count times, the point that brings the samples'
// mass-weighted projection of each sub-step's velocity increment closest, in kinetic energy, to the all-point one
// over the snapshots (Algorithm 1's; the Galerkin step's are refused), then exchanges samples while that lowers the
// error. Weights: the masses; with snapshots.settings.weighting Cubature, refitted by Gauss-Newton on the same error.
// misfits: the increments' relative error (sqrt of the error's energy over the all-point increments'), then with
// the weights.
CubatureFit greedy_projection_selection(const Model& model, const CubatureSnapshots& snapshots, std::size_t count);
// The same with the snapshots gathered once (an all-point rollout or sub-step each): select() for several counts.
// Where snapshots.settings.selection_sensitivities holds a positive weight, the snapshots also hold the increments'
// response to the latent state (at each state one latent coordinate a rollout, cycling, moved by 1 % of the codes'
// spread; scaled to the increments' energy), which select() then weighs in.
class ProjectionSelector {
 public:
  ProjectionSelector(const Model& model, const CubatureSnapshots& snapshots);
  // count samples; fit: also fit their weights (else their masses). sensitivity: the weight of the increments'
  // response to the latent state in the error (RomSettings::selection_sensitivities; 0: the increments alone).
  CubatureFit select(std::size_t count, bool fit, double sensitivity) const;

 private:
  struct Increments;
  std::shared_ptr<const Increments> increments_;
};

// Node set, neighbours and quadrature points for the given samples, from the motion of the model's training codes:
// all of them, or those listed in `codes` (a probe from a few training states needs only theirs and their
// neighbours in time; the sets then cover the paths between listed codes that follow each other in time).
HyperReduction build_hyper_reduction(const Model& model, const Scene& scene, const RomSettings& settings,
                                     const std::vector<int>& samples, const std::vector<int>& codes = {});

// Everything settings ask of the hyper-reduction: the samples (select_samples, or the greedy projection's: the
// model's stored set when it has one of settings.samples, else fitted to the snapshots), their sets, and their
// weights (fitted_weights). data: the training runs, for --data / --cubature-snapshots full. log receives one line
// per fit (what it fitted and its relative error); may be empty. selector, if given, is asked for the snapshots of
// these settings only when a set must be fitted (a study's cache, for several counts on one model). The stored set
// applies at the time step and projection it was fitted with (the defaults); other steps fit their own.
using SelectorSource = std::function<const ProjectionSelector&(const RomSettings&)>;
HyperReduction prepare_hyper_reduction(const Model& model, const Scene& scene, const RomSettings& settings,
                                       const TrainingData* data, const std::function<void(const std::string&)>& log,
                                       const SelectorSource& selector = {});

// The snapshots the stored set is fitted to: the reduced motion on the scene with RomSettings' defaults.
ProjectionSelector default_projection_selector(const Model& model, const Scene& scene);
// The greedy projection set with fitted weights that `mpmrom train --scene` and the pipeline store with a model
// (Model::projection_samples), count samples chosen among RomSettings' default trial sets, from
// default_projection_selector's snapshots on the scene.
void store_projection_samples(Model& model, const Scene& scene, const ProjectionSelector& selector, std::size_t count,
                              const std::function<void(const std::string&)>& log);

// One rollout: parameter values (in the order of the batch's parameter names) and, if known, its split.
struct RolloutCase {
  std::vector<double> values;
  std::string split;  // "train", "test" or empty
};

struct RolloutOutcome {
  int flags = 0;             // src/rom/kernels/sources.hpp RolloutFlag bits
  int frames_completed = 0;  // output frames written before a fatal flag stopped it
  double stopped_at = -1;    // time of the failure (s), -1 if none
  double max_condition = 0;  // largest condition estimate of its normal equations
  long regularized_steps = 0;
  long inversion_failures = 0;   // Algorithm 2: failed inversions, all steps
  long inversion_fallbacks = 0;  // of which the point used its previous step's solution
  std::string message;           // empty, or one line on what happened
  std::string warning;           // empty, or one line: parameters outside the training range
};

struct RomResult {
  std::vector<std::string> parameter_names;
  std::vector<RolloutCase> cases;
  int latent_dim = 0;
  std::vector<double> times;          // output times (frames)
  std::vector<double> xhat, xhatdot;  // (rollouts, frames, r)
  std::vector<RolloutOutcome> outcomes;
  long steps = 0;            // time steps taken (each advances every rollout)
  double step_seconds = 0;   // wall time of the stepping alone, all steps
  double setup_seconds = 0;  // initial projection and device set-up
  // The points at which a rollout's sub-step evaluates the network (BatchStepperBase::evaluated_points).
  std::size_t evaluated_points = 0;
};

struct RomProgress {
  int frame = 0, frames = 0;
  double time = 0;
  long steps = 0;
  double seconds = 0;
};

// The fastest motion of the training codes, max |code(t_k+1) - code(t_k)| / (t_k+1 - t_k) within a run: the scale of
// the latent speed limit (RomSettings::energy_growth).
double training_latent_speed(const Model& model);

// One line per parameter of `values` outside the range the model's training runs spanned (from the [design] of the
// scene the model was trained on), with the distance in widths of that range; empty when all lie inside.
std::string training_range_warning(const Model& model, const std::vector<std::string>& names,
                                   const std::vector<double>& values);
// The same for every rollout of a batch, the model's scene parsed once.
std::vector<std::string> training_range_warnings(const Model& model, const std::vector<std::string>& names,
                                                 const std::vector<RolloutCase>& cases);

// Where a long batch of rollouts saves its state (docs/reliability.md): path empty for none. A checkpoint names its
// batch (a hash of the model's weights, the scene file, the settings and the rollouts' parameters); one of another
// batch is refused on resume.
struct RolloutCheckpoint {
  std::string path;
  double seconds = 60;  // wall-clock time between checkpoints (taken at output frames)
  bool resume = false;  // go on from the checkpoint at path if there is one
};

// Advances every case from the scene's initial state (projected onto the manifold) to its end time, recording the
// latent state at the scene's output times. scene_path: the scene file whose parameters the cases set.
RomResult run_rollouts(const Model& model, const std::string& scene_path, const std::vector<std::string>& names,
                       const std::vector<RolloutCase>& cases, const RomSettings& settings,
                       const HyperReduction& reduction, const std::function<void(const RomProgress&)>& progress = {},
                       const RolloutCheckpoint& checkpoint = {});

// run_rollouts spread over the ranks of comm (src/core/parallel.hpp): each rank advances a contiguous share of the
// cases (parallel::share_of) and the shares take one time step, so the result equals run_rollouts' on one process bit
// for bit. Rank 0 returns the whole batch, the other ranks their own share. progress is called on rank 0. Each rank
// checkpoints its share into checkpoint.path + ".rank<k>" (docs/mpi.md).
RomResult run_rollouts(const parallel::Communicator& comm, const Model& model, const std::string& scene_path,
                       const std::vector<std::string>& names, const std::vector<RolloutCase>& cases,
                       const RomSettings& settings, const HyperReduction& reduction,
                       const std::function<void(const RomProgress&)>& progress = {},
                       const RolloutCheckpoint& checkpoint = {});
// The checkpoint file of rank `rank` of `size` for a batch whose checkpoint is path.
std::string rank_checkpoint_path(const std::string& path, int rank, int size);

// Decoded fields of one rollout at points X (n, 3): x, v (frames, n, 3) and F (frames, n, 3, 3) from the latent
// states codes and rates (frames, r).
struct DecodedFields {
  std::vector<double> x, v, F;
};
DecodedFields decode(const Model& model, const std::vector<double>& X, const std::vector<double>& codes,
                     const std::vector<double>& rates);

}  // namespace mpmrom
