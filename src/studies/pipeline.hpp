// The whole chain on one scene (SPEC.md `mpmrom pipeline`): the parameter sweep, full-order runs of the test
// parameters at several resolutions against a finer reference, training, reduced rollouts in several configurations,
// their errors and costs, and a report (report.json with every figure, report.md with charts) in one directory.
// Also the search for the cheapest reduced model that meets a target error (`--target-error`), used by the pipeline
// and by `mpmrom train`. docs/pipeline.md describes the method, the cost measure and the outputs.
#pragma once

#include <nlohmann/json.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mpmrom/rom.hpp"
#include "manifold/trainer.hpp"

namespace mpmrom {

// A network shape: latent dimension r, hidden width and affine layers.
struct NetworkShape {
  int latent_dim = 5, width = 48, depth = 5;
  std::string name() const;                            // "r5_w48_d5"
  static NetworkShape parse(const std::string& text);  // "5x48x5" (r x width x depth); throws std::invalid_argument
};

// One reduced-model configuration on a trained network.
struct RomConfiguration {
  RomMethod method = RomMethod::MaterialPoint;
  int samples = 15;          // 0: all points
  double cfl = 0;            // 0: the scene's
  std::string name() const;  // "point_s15_cfl0.3"
};

struct PipelineSettings {
  std::string scene_path, out_dir;
  // FOM resolutions (grid and particle spacing divided by each) and the reference they are measured against.
  std::vector<double> fom_refinements{0.5, 0.75, 1.0, 1.5};
  std::vector<double> fom_cfls{0};  // CFL numbers for the FOM ladder (0: the scene's)
  double reference_refinement = 2.0;
  // Networks to train (empty: the training settings' own shape, or the search space with targets).
  std::vector<NetworkShape> networks;
  TrainingSettings training;  // everything but the shape
  std::vector<RomMethod> methods{RomMethod::MaterialPoint, RomMethod::Galerkin};
  std::vector<int> samples{8, 15, 30, 0};
  std::vector<double> rom_cfls{0, 3.0};
  std::optional<SampleSelection> selection;  // nullopt: each method's, as the rollout's defaults (docs/rom.md)
  int validation_runs = -1;           // training runs held out to choose models (-1: about a sixth of them, at least 1)
  std::vector<double> target_errors;  // position_error targets for the model search (fractions; empty: no search)
  std::vector<int> batch_sizes{1, 4, 16, 64};  // batch throughput of the chosen (or only) configuration
  double batch_end_time = 0;                   // horizon of the batch benchmark (0: 4 output intervals)
  std::string command;  // the command line, for the report (empty: one is made from the scene and directory)
};

// The search space of --target-error when no networks are given: r in {3, 5, 8} x width in {16, 32, 48}, the
// training settings' depth.
std::vector<NetworkShape> default_search_networks(int depth);

// Training runs of the scene's design held out to choose models (indices into design.all_runs()): those with the
// most parameters at interior levels (like the test runs, interpolation cases), evenly spread in design order.
// requested < 0: about a sixth of the training runs, at least one.
std::vector<std::size_t> validation_runs(const Scene& scene, int requested);

// Indices of the points on the lower-left Pareto front of (cost, error), by increasing cost; non-finite errors
// (failed configurations) are never on it.
std::vector<std::size_t> pareto_front(const std::vector<double>& cost, const std::vector<double>& error);

// Progress: one line per stage or finished item.
using PipelineLog = std::function<void(const std::string&)>;

// Runs the pipeline into settings.out_dir and returns report.json's content (also written there with report.md and
// the charts). Reuses a finished sweep (DIR/data/design.csv) and trained models (DIR/models/*.h5 trained with the
// same settings), so a stopped pipeline continues where it was.
nlohmann::json run_pipeline(const PipelineSettings& settings, const PipelineLog& log = {});

// `mpmrom train --target-error`: the model search alone on an existing sweep directory. Trains candidates under
// work_dir, returns the decision per target (what was chosen, its validation and test errors and cost, why) and
// copies the chosen model of the first target to model_path. Throws std::runtime_error if no candidate meets it.
nlohmann::json search_model(const std::string& scene_path, const std::string& sweep_dir, const std::string& work_dir,
                            const std::string& model_path, const PipelineSettings& settings,
                            const PipelineLog& log = {});

}  // namespace mpmrom
