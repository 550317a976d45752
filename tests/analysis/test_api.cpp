// The deployment API (rollout_batch.hpp) against the batch driver the command line uses: a batch advanced output
// interval by output interval reproduces run_rollouts bit for bit (same kernels, same order, same backend), decodes
// to the same fields, and refuses bad requests with a clear error.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

#include "mpmrom/model.hpp"
#include "fixtures.hpp"
#include "mpmrom/rollout_batch.hpp"
#include "rom/rom_file.hpp"
#include "analysis/evaluation.hpp"
#include "snapshots/simulate.hpp"
#include "manifold/trainer.hpp"
#include "mpmrom/training_data.hpp"

namespace mpmrom::test {
namespace {

namespace fs = std::filesystem;

// Three pushes; 4 output frames over 0.04 s.
const std::string kScene = pushed_block_scene("pushed_block", 0.04, 4, 0.4, {0.5, 1.0, 1.5}, 1);

class RolloutBatchApi : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mpmrom-test-api-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(scene_path()) << kScene;
    sweep(scene_path(), (dir_ / "sweep").string(), default_p2g_strategy());
    TrainingSettings settings;
    settings.latent_dim = 2;
    settings.width = 8;
    settings.depth = 3;
    settings.epochs = 30;
    const auto data = load_training_data({(dir_ / "sweep").string()});
    save_model(unranked_model_path(), train_model(data, settings, "", false));
    Model model = load_model(unranked_model_path());  // the weights as stored, in the build's precision
    model.sample_ranking = rank_samples_greedily(model, data, ranked_samples);  // as `mpmrom train` stores it
    store_projection_samples(model, default_projection_selector(model, load_scene(scene_path())),
                             std::size_t(RolloutBatchApi::settings().samples), {});
    save_model(model_path(), model);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string scene_path() { return (dir_ / "scene.toml").string(); }
  static std::string model_path() { return (dir_ / "model.h5").string(); }
  static std::string unranked_model_path() { return (dir_ / "unranked_model.h5").string(); }

  static RomSettings settings() {
    RomSettings s;
    s.samples = 8;
    return s;
  }

  static fs::path dir_;
};
fs::path RolloutBatchApi::dir_;

TEST_F(RolloutBatchApi, SteppingFrameByFrameReproducesTheBatchDriver) {
  const auto rom = ReducedModel::load(model_path(), scene_path(), settings());
  ASSERT_EQ(rom.parameter_names(), std::vector<std::string>{"push"});
  const std::vector<std::vector<double>> pushes{{0.5}, {1.25}, {1.5}};
  auto batch = rom.batch(pushes);
  ASSERT_EQ(batch.size(), 3);
  ASSERT_EQ(batch.frames(), 5);

  std::vector<RolloutCase> cases;
  for (const auto& p : pushes) cases.push_back({p, ""});
  const RomResult reference =
      run_rollouts(rom.model(), scene_path(), rom.parameter_names(), cases, rom.settings(), rom.hyper_reduction());
  const std::size_t r = std::size_t(batch.latent_dim()), frames = std::size_t(batch.frames());
  EXPECT_EQ(batch.times(), reference.times);
  for (std::size_t frame = 0; frame < frames; ++frame) {
    ASSERT_EQ(batch.frame(), int(frame));
    const auto xhat = batch.latent_state(), xhatdot = batch.latent_rate();
    for (std::size_t b = 0; b < 3; ++b)
      for (std::size_t q = 0; q < r; ++q) {
        ASSERT_EQ(xhat[b * r + q], reference.xhat[(b * frames + frame) * r + q])
            << "frame " << frame << " rollout " << b;
        ASSERT_EQ(xhatdot[b * r + q], reference.xhatdot[(b * frames + frame) * r + q]);
      }
    EXPECT_EQ(batch.advance(), frame + 1 < frames);
  }
  EXPECT_FALSE(batch.advance());  // at the horizon it stays
  EXPECT_EQ(batch.frame(), int(frames) - 1);
  EXPECT_EQ(batch.steps(), reference.steps);
  const auto outcomes = batch.outcomes();
  for (std::size_t b = 0; b < 3; ++b) {
    EXPECT_EQ(outcomes[b].flags, reference.outcomes[b].flags);
    EXPECT_EQ(outcomes[b].frames_completed, int(frames));
    EXPECT_TRUE(batch.running(int(b)));
  }

  // Decoding the batch now equals decoding the recorded last frame.
  const auto& X = rom.reference_points();
  const DecodedFields now = batch.decode(1, X);
  const std::size_t last = (1 * frames + frames - 1) * r;
  const DecodedFields recorded =
      decode(rom.model(), X, {reference.xhat.begin() + last, reference.xhat.begin() + last + r},
             {reference.xhatdot.begin() + last, reference.xhatdot.begin() + last + r});
  EXPECT_EQ(now.x, recorded.x);
  EXPECT_EQ(now.v, recorded.v);
  EXPECT_EQ(now.F, recorded.F);
  ASSERT_EQ(now.x.size(), X.size());
}

TEST_F(RolloutBatchApi, ParametersOutsideTheTrainingRangeAreWarnedAbout) {
  const auto rom = ReducedModel::load(model_path(), scene_path(), settings());
  const auto batch = rom.batch({{1.0}, {2.5}});
  const auto outcomes = batch.outcomes();
  EXPECT_TRUE(outcomes[0].warning.empty()) << outcomes[0].warning;
  EXPECT_NE(outcomes[1].warning.find("push = 2.5 lies outside the training range [0.5, 1.5]"), std::string::npos)
      << outcomes[1].warning;
}

// Greedy selection is nested (each step adds the point that lowers the projection residual most, given those before):
// the stored ranking's first k points are the greedy selection of k refitted to the training runs, for every k.
TEST_F(RolloutBatchApi, StoredSampleRankingIsTheGreedySelection) {
  Model model = load_model(model_path());
  const Scene scene = load_scene(scene_path());
  const auto data = load_training_data({(dir_ / "sweep").string()});
  ASSERT_EQ(model.sample_ranking.size(), std::min(ranked_samples, model.num_points()));
  RomSettings s = settings();
  s.selection = SampleSelection::Greedy;
  for (const int k : {1, 5, 8, 20}) {
    s.samples = k;
    const auto from_model = select_samples(model, scene, s, nullptr);
    EXPECT_EQ(from_model, select_samples(model, scene, s, &data)) << k << " samples";
    EXPECT_EQ(from_model.size(), std::size_t(k));
  }
  model.sample_ranking.resize(4);  // fewer ranked points than asked for: refused, naming the remedy
  try {
    select_samples(model, scene, s, nullptr);
    ADD_FAILURE() << "a ranking of 4 points gave " << s.samples << " samples";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("pass --data"), std::string::npos) << e.what();
  }
}

// No chosen sample of `fit` swapped for a point outside it lowers the total misfit of weights refitted to the new
// set. The exchange swaps for a drop of the squared misfit above 1e-10 (the targets have unit norm a block); the
// refit agrees with the exchange's own solve to rounding, far below the 1e-8 allowed here.
template <class Total>
void expect_no_better_swap(const Model& model, const CubatureSnapshots& snapshots, const CubatureFit& fit,
                           const Total& total, const std::string& source) {
  const double misfit2 = total(fit) * total(fit);
  for (std::size_t slot = 0; slot < fit.samples.size(); ++slot)
    for (int p = 0; p < int(model.num_points()); ++p) {
      if (std::find(fit.samples.begin(), fit.samples.end(), p) != fit.samples.end()) continue;
      std::vector<int> swapped = fit.samples;
      swapped[slot] = p;
      const double t = total(cubature_weights(model, snapshots, swapped));
      EXPECT_GE(t * t, misfit2 - 1e-8) << source << ": sample " << fit.samples[slot] << " -> " << p;
    }
}

// Cubature (ECSW), from the full-order runs and from the reduced motion: the active set's samples carry positive
// weights, at most as many as asked for; a larger count's fit has no larger total misfit; the exchange passes leave
// the count-limited choice a local optimum (no sample swapped for another point lowers the refitted misfit); refitting
// weights to the chosen samples (cubature_weights) reproduces the selection's weights, the same restricted
// least-squares problem. With every point as a sample the masses are an exact solution, so the misfit is only the
// normal equations' rounding and ridge. The Galerkin step's reduced motion fits its own three blocks: the mass matrix,
// the momentum J^T v and the reduced force.
TEST_F(RolloutBatchApi, CubatureSelectionAndWeightsFitTheAllPointSums) {
  const Model model = load_model(model_path());
  const auto data = load_training_data({(dir_ / "sweep").string()});
  const auto total = [](const CubatureFit& fit) {
    double sum = 0;
    for (const double m : fit.misfits) sum += m * m;
    return std::sqrt(sum);
  };
  CubatureSnapshots full_order;
  full_order.data = &data;
  CubatureSnapshots reduced;
  reduced.scene_path = scene_path();
  reduced.count = 2;
  CubatureSnapshots galerkin = reduced;
  galerkin.settings.method = RomMethod::Galerkin;
  for (const CubatureSnapshots& snapshots : {full_order, reduced, galerkin}) {
    const bool is_galerkin = snapshots.settings.method == RomMethod::Galerkin;
    const std::string source = snapshots.data ? "full-order runs" : is_galerkin ? "galerkin motion" : "reduced motion";
    // blocks: the normal matrix, then velocity and acceleration (full order), the sub-step's velocity increment
    // (Algorithm 1's motion) or the momentum and the reduced force (Galerkin)
    const std::size_t blocks = snapshots.data || is_galerkin ? 3 : 2;
    double previous = std::numeric_limits<double>::infinity();
    for (const std::size_t count : {3, 6, 12}) {
      const CubatureFit fit = cubature_selection(model, snapshots, count);
      ASSERT_FALSE(fit.samples.empty()) << source;
      EXPECT_EQ(fit.misfits.size(), blocks) << source;
      EXPECT_LE(fit.samples.size(), count) << source;
      for (const double w : fit.weights) EXPECT_GT(w, 0.0) << source;
      EXPECT_LE(total(fit), previous * (1 + 1e-9)) << source << " " << count;
      previous = total(fit);
      if (count == 6 && fit.samples.size() == count) expect_no_better_swap(model, snapshots, fit, total, source);
      const CubatureFit refit = cubature_weights(model, snapshots, fit.samples);
      ASSERT_EQ(refit.weights.size(), fit.weights.size());
      // passive-set solves of the same small system, both with the same ridge: agreement far below 1e-6
      for (std::size_t i = 0; i < fit.weights.size(); ++i)
        EXPECT_NEAR(refit.weights[i], fit.weights[i], 1e-6 * fit.weights[i]) << source << " " << count;
    }
    std::vector<int> all(model.num_points());
    std::iota(all.begin(), all.end(), 0);
    EXPECT_LE(total(cubature_weights(model, snapshots, all)), 1e-4) << source;  // the ridge's 1e-12, square-rooted
  }
}

// The Galerkin step's weights fitted to the grid step's force (CubatureTarget::Grid), from the reduced motion and
// from the training states: the force gets weights of its own, fitted to the force Algorithm 1's all-point sub-step
// applies, and the mass matrix and momentum theirs. Over every point the masses solve the mass and momentum blocks
// exactly (misfit: the normal equations' ridge, as in the test above); the force block's misfit stays below 1 (a
// sign error leaves it at 1: no non-negative weights fit an opposite force). The selection's samples are the force
// fit's active set, fitted at the scene's time step for a rollout at a longer one. The grid step's own snapshots and
// the full-order runs are refused.
TEST_F(RolloutBatchApi, GalerkinWeightsFitTheGridStepsForce) {
  const Model model = load_model(model_path());
  CubatureSnapshots reduced;
  reduced.scene_path = scene_path();
  reduced.count = 2;
  reduced.settings.method = RomMethod::Galerkin;
  reduced.settings.cubature_target = CubatureTarget::Grid;
  CubatureSnapshots states = reduced;
  states.settings.snapshot_source = SnapshotSource::States;
  std::vector<int> all(model.num_points());
  std::iota(all.begin(), all.end(), 0);
  for (const CubatureSnapshots& snapshots : {reduced, states}) {
    const std::string source = to_string(snapshots.settings.snapshot_source);
    const CubatureFit every = cubature_weights(model, snapshots, all);
    ASSERT_EQ(every.misfits.size(), 3u) << source;
    ASSERT_EQ(every.force_weights.size(), all.size()) << source;
    EXPECT_LE(every.misfits[0], 1e-4) << source;
    EXPECT_LE(every.misfits[1], 1e-4) << source;
    EXPECT_LT(every.misfits[2], 0.5) << source;
    // the samples are the force fit's active set; the mass and momentum weights on them may be 0
    const CubatureFit few = cubature_selection(model, snapshots, 6);
    ASSERT_FALSE(few.samples.empty()) << source;
    ASSERT_EQ(few.force_weights.size(), few.samples.size()) << source;
    for (const double w : few.force_weights) EXPECT_GT(w, 0.0) << source;
    for (const double w : few.weights) EXPECT_GE(w, 0.0) << source;
  }
  RomSettings grid_step = reduced.settings;
  grid_step.method = RomMethod::MaterialPoint;
  EXPECT_THROW(grid_step.validate(), std::invalid_argument);
  RomSettings from_runs = reduced.settings;
  from_runs.snapshot_source = SnapshotSource::Full;
  EXPECT_THROW(from_runs.validate(), std::invalid_argument);
  // A rollout at a longer time step than the scene's takes the weights fitted at the scene's (the grid step's force)
  const Scene scene = load_scene(scene_path());
  RomSettings longer = states.settings;
  longer.cfl = 4 * scene.cfl;
  const CubatureFit at_scene = cubature_selection(model, cubature_snapshots(scene, states.settings, nullptr), 6);
  const CubatureSnapshots fitted_longer = cubature_snapshots(scene, longer, nullptr);
  EXPECT_EQ(fitted_longer.settings.cfl, 0.0);  // the scene's
  const CubatureFit at_longer = cubature_selection(model, fitted_longer, 6);
  EXPECT_EQ(at_longer.samples, at_scene.samples);
  EXPECT_EQ(at_longer.force_weights, at_scene.force_weights);
  // --cubature-candidates: fewer candidates than points restrict the selection to them
  RomSettings sixteen = states.settings;
  sixteen.cubature_candidates = 16;
  sixteen.validate();
  const CubatureSnapshots on_sixteen = cubature_snapshots(load_scene(scene_path()), sixteen, nullptr);
  ASSERT_EQ(on_sixteen.max_candidates, 16u);
  ASSERT_GT(model.num_points(), 16u) << "the test needs a body of more than 16 points";
  std::vector<int> drawn;  // the samples of fits of 6 and of 40: all among the same 16 points
  for (const std::size_t count : {6, 40})
    for (const int p : cubature_selection(model, on_sixteen, count).samples) drawn.push_back(p);
  std::sort(drawn.begin(), drawn.end());
  EXPECT_LE(std::unique(drawn.begin(), drawn.end()) - drawn.begin(), 16);
  sixteen.cubature_candidates = 8;
  EXPECT_THROW(sixteen.validate(), std::invalid_argument);
}

// The held-out check of the cubature fits: on a design whose two training runs are the same run, the run held out
// is the one the fit kept, whose normal equations are half the whole system's (the whole minus the held run's), so
// the fit without it has the same minimiser and its misfit over the held-out run equals the fit's own; a design of
// one training run has nothing to hold out; of two different runs, the held-out one is not fitted. Tolerance 1e-6: the
// weights differ by the rounding of G - G_held and of the active-set solves, relative 1e-12 or so, amplified by
// conditioning far below 1e6 on this small system.
TEST_F(RolloutBatchApi, CubatureHeldOutRunOfATwiceTakenRunMatchesTheFit) {
  const Model model = load_model(model_path());
  const std::string twice = (dir_ / "twice.toml").string(), once = (dir_ / "once.toml").string();
  std::ofstream(twice) << pushed_block_scene("pushed_block", 0.04, 4, 0.4, {1.0, 1.0, 1.5}, 2);
  std::ofstream(once) << pushed_block_scene("pushed_block", 0.04, 4, 0.4, {1.0, 1.5}, 1);
  CubatureSnapshots point;
  point.scene_path = twice;
  point.count = 2;
  CubatureSnapshots galerkin = point;
  galerkin.settings = rom_defaults(RomMethod::Galerkin);
  galerkin.settings.snapshot_source = SnapshotSource::Reduced;  // the states would be the model's codes of run 1
  for (const CubatureSnapshots& snapshots : {point, galerkin}) {
    const std::string method = to_string(snapshots.settings.method);
    for (const CubatureFit& fit : {cubature_selection(model, snapshots, 5), cubature_selection(model, snapshots, 0)}) {
      ASSERT_EQ(fit.held_out_misfits.size(), fit.misfits.size()) << method;
      for (std::size_t b = 0; b < fit.misfits.size(); ++b)
        EXPECT_NEAR(fit.held_out_misfits[b], fit.misfits[b], 1e-6 * (1 + fit.misfits[b])) << method << " block " << b;
    }
    CubatureSnapshots single = snapshots;
    single.scene_path = once;
    EXPECT_TRUE(cubature_selection(model, single, 5).held_out_misfits.empty()) << method;
  }
  // Two different runs: with every point a candidate the unlimited fit reproduces both runs' mass matrices (the
  // masses do, misfit below 1e-6 as above), while the fit that never saw the second run leaves a misfit on it.
  const std::string two = (dir_ / "two.toml").string();
  std::ofstream(two) << pushed_block_scene("pushed_block", 0.04, 4, 0.4, {1.0, 1.5, 1.25}, 2);
  point.scene_path = two;
  const CubatureFit unlimited = cubature_selection(model, point, 0);
  ASSERT_EQ(unlimited.held_out_misfits.size(), unlimited.misfits.size());
  EXPECT_LT(unlimited.misfits[0], 1e-6);
  EXPECT_GT(unlimited.held_out_misfits[0], 10 * unlimited.misfits[0] + 1e-9);
}

// The training states are those of the runs the model was trained on: a design with a training run the model never
// saw (the pipeline holds some out to validate) fits over the others instead of stopping at the run it has no codes
// of; the fit still holds a run out (two runs are left). A design none of whose runs the model holds is refused.
TEST_F(RolloutBatchApi, TrainingStatesTakeTheRunsTheModelWasTrainedOn) {
  const Model model = load_model(model_path());
  const std::string wider = (dir_ / "wider.toml").string(), other = (dir_ / "other.toml").string();
  std::ofstream(wider) << pushed_block_scene("pushed_block", 0.04, 4, 0.4, {0.5, 1.0, 1.5, 1.25}, 1);
  std::ofstream(other) << pushed_block_scene("pushed_block", 0.04, 4, 0.4, {0.5, 1.0}, 0);
  CubatureSnapshots states;
  states.scene_path = wider;
  states.count = 8;
  states.settings = rom_defaults(RomMethod::Galerkin);
  const CubatureFit fit = cubature_selection(model, states, 4);
  EXPECT_FALSE(fit.samples.empty());
  EXPECT_EQ(fit.held_out_misfits.size(), fit.misfits.size());
  states.scene_path = other;  // its one training run is run 1, the model's test run
  EXPECT_THROW(cubature_selection(model, states, 4), std::runtime_error);
}

// Greedy selection on the projection, over the reduced motion and over the training states (one sub-step from each):
// as many samples as asked for, distinct, weighted by their masses; with every point as a candidate taken, the
// samples' projection is the all-point one, so the error is only the selection's ridge (1e-8 of the trace, relative
// error far below 1e-6); weights refitted by Gauss-Newton start from the masses and keep only improvements, so their
// error is at most the masses'. The Galerkin step's snapshots are refused with a line that names the remedy.
TEST_F(RolloutBatchApi, GreedyProjectionSelectionApproachesTheAllPointProjection) {
  const Model model = load_model(model_path());
  CubatureSnapshots reduced;
  reduced.scene_path = scene_path();
  reduced.count = 2;
  reduced.settings.weighting = SampleWeighting::Mass;
  CubatureSnapshots states = reduced;
  states.settings.snapshot_source = SnapshotSource::States;
  for (const CubatureSnapshots& snapshots : {reduced, states}) {
    const std::string source = to_string(snapshots.settings.snapshot_source);
    for (const std::size_t count : {4, 10}) {
      const CubatureFit fit = greedy_projection_selection(model, snapshots, count);
      ASSERT_EQ(fit.samples.size(), count) << source;
      ASSERT_EQ(fit.misfits.size(), 1u) << source;
      EXPECT_GT(fit.misfits[0], 0.0) << source;
      std::vector<int> sorted = fit.samples;
      std::sort(sorted.begin(), sorted.end());
      EXPECT_EQ(std::unique(sorted.begin(), sorted.end()), sorted.end()) << source;
      for (std::size_t k = 0; k < count; ++k) EXPECT_EQ(fit.weights[k], model.mass[std::size_t(fit.samples[k])]);
    }
    CubatureSnapshots weighted = snapshots;
    weighted.settings.weighting = SampleWeighting::Cubature;
    const CubatureFit fit = greedy_projection_selection(model, weighted, 6);
    ASSERT_EQ(fit.misfits.size(), 2u) << source;
    EXPECT_LE(fit.misfits[1], fit.misfits[0]) << source;
    for (const double w : fit.weights) EXPECT_GT(w, 0.0) << source;
    const CubatureFit every = greedy_projection_selection(model, snapshots, model.num_points());
    EXPECT_LT(every.misfits[0], 1e-6) << source;
  }
  // A body larger than the candidates: the training-state snapshots hold the candidates alone, whose projection
  // is then the reference (all of them taken: no error); a fit that needs other points' rows is refused.
  CubatureSnapshots sampled = states;
  sampled.max_candidates = model.num_points() / 3;
  const CubatureFit few = greedy_projection_selection(model, sampled, 4);
  ASSERT_EQ(few.samples.size(), 4u);
  EXPECT_GT(few.misfits[0], 0.0);
  const CubatureFit all_candidates = greedy_projection_selection(model, sampled, sampled.max_candidates + 1);
  EXPECT_LT(all_candidates.misfits[0], 1e-6);
  EXPECT_LE(all_candidates.samples.size(), sampled.max_candidates + 1);
  std::vector<int> outside(1, -1);
  for (int p = 0; outside[0] < 0; ++p)
    if (std::find(all_candidates.samples.begin(), all_candidates.samples.end(), p) == all_candidates.samples.end())
      outside[0] = p;
  EXPECT_THROW(cubature_weights(model, sampled, outside), std::invalid_argument);
  CubatureSnapshots galerkin = reduced;
  galerkin.settings.method = RomMethod::Galerkin;
  try {
    greedy_projection_selection(model, galerkin, 4);
    ADD_FAILURE() << "the Galerkin step's snapshots were accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--method point"), std::string::npos) << e.what();
  }
}

// The default hyper-reduction: the set `mpmrom train --scene` stores is the greedy projection selection with fitted
// weights (the same deterministic computation), a rollout of that count uses it as stored (its weights, or the
// masses with --weights mass), and another count, or a model without a stored set, is fitted at set-up.
TEST_F(RolloutBatchApi, StoredProjectionSetIsTheDefaultHyperReduction) {
  const Model model = load_model(model_path()), unranked = load_model(unranked_model_path());
  const Scene scene = load_scene(scene_path());
  RomSettings s = settings();
  ASSERT_EQ(s.selection, SampleSelection::GreedyProjection);
  ASSERT_EQ(fitted_weights(s), SampleWeighting::Cubature);
  ASSERT_EQ(model.projection_samples.size(), std::size_t(s.samples));
  ASSERT_TRUE(unranked.projection_samples.empty());
  const HyperReduction stored = prepare_hyper_reduction(model, scene, s, nullptr, {});
  const HyperReduction fitted = prepare_hyper_reduction(unranked, scene, s, nullptr, {});
  EXPECT_EQ(stored.samples, std::vector<int>(model.projection_samples.begin(), model.projection_samples.end()));
  EXPECT_EQ(stored.weights, model.projection_weights);
  EXPECT_EQ(fitted.samples, stored.samples);
  EXPECT_EQ(fitted.weights, stored.weights);
  s.weighting = SampleWeighting::Mass;
  const HyperReduction masses = prepare_hyper_reduction(model, scene, s, nullptr, {});
  EXPECT_EQ(masses.samples, stored.samples);
  EXPECT_TRUE(masses.weights.empty());  // empty: the samples' masses
  s.weighting = SampleWeighting::Auto;
  s.samples = 5;
  CubatureSnapshots snapshots = cubature_snapshots(scene, s, nullptr);
  snapshots.settings.weighting = SampleWeighting::Cubature;
  const CubatureFit five = greedy_projection_selection(model, snapshots, 5);
  const HyperReduction other_count = prepare_hyper_reduction(model, scene, s, nullptr, {});
  EXPECT_EQ(other_count.samples, five.samples);
  EXPECT_EQ(other_count.weights, five.weights);
  s.selection = SampleSelection::Region;  // auto weights: the masses for a selection that fits none
  EXPECT_TRUE(prepare_hyper_reduction(model, scene, s, nullptr, {}).weights.empty());
  // The stored count at another time step: fitted to that step's motion, not the stored set; the scene's own CFL
  // number given explicitly is the default step, and the stored set applies.
  s = settings();
  s.cfl = 3 * scene.cfl;
  CubatureSnapshots at_cfl = cubature_snapshots(scene, s, nullptr);
  at_cfl.settings.weighting = SampleWeighting::Cubature;
  const CubatureFit refit = greedy_projection_selection(model, at_cfl, std::size_t(s.samples));
  const ProjectionSelector selector(model, at_cfl);
  int asked = 0;
  const auto count_asks = [&](const RomSettings&) -> const ProjectionSelector& {
    ++asked;
    return selector;
  };
  const HyperReduction other_step = prepare_hyper_reduction(model, scene, s, nullptr, {}, count_asks);
  EXPECT_EQ(asked, 1);
  EXPECT_EQ(other_step.samples, refit.samples);
  EXPECT_EQ(other_step.weights, refit.weights);
  s.cfl = scene.cfl;
  EXPECT_EQ(prepare_hyper_reduction(model, scene, s, nullptr, {}, count_asks).samples, stored.samples);
  EXPECT_EQ(asked, 1);  // the stored set: no snapshots asked for
}

// `mpmrom evaluate` against a fresh sweep of new parameter points, all of them marked test: every rollout finds its
// reference run and the errors are reported under test, while training still needs a training run.
TEST_F(RolloutBatchApi, EvaluationTakesReferenceRunsOfAnySplit) {
  const fs::path all_test = dir_ / "sweep_all_test";
  fs::remove_all(all_test);
  fs::copy(dir_ / "sweep", all_test, fs::copy_options::recursive);
  std::ifstream in(all_test / "design.csv");
  std::string header, line, rows;
  std::getline(in, header);
  while (std::getline(in, line)) {
    const auto train = line.find(",train,");
    rows += (train == std::string::npos ? line : line.replace(train, 7, ",test,")) + "\n";
  }
  in.close();
  ASSERT_EQ(rows.find("train"), std::string::npos) << rows;
  std::ofstream(all_test / "design.csv") << header << "\n" << rows;
  EXPECT_THROW(load_training_data({all_test.string()}), std::runtime_error);

  const auto rom = ReducedModel::load(model_path(), scene_path(), settings());
  std::vector<RolloutCase> cases;
  for (const double push : {0.5, 1.0, 1.5}) cases.push_back({{push}, ""});
  RomFile file;
  file.result =
      run_rollouts(rom.model(), scene_path(), rom.parameter_names(), cases, rom.settings(), rom.hyper_reduction());
  const auto errors = evaluate_rom(file, rom.model(), load_runs({all_test.string()}));
  EXPECT_EQ(errors["matched"], 3);
  EXPECT_TRUE(std::isfinite(errors["test"]["position_error"].get<double>())) << errors.dump();
  EXPECT_EQ(errors["test"]["position_error"], errors["position_error"]);  // all three are test runs
  // Per output time: the aggregate is a weighted root mean square of the frames' errors, so it lies between them.
  const auto& frames = errors["frames"];
  ASSERT_EQ(frames.size(), file.result.times.size());
  double lowest = 1e300, highest = 0;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    EXPECT_EQ(frames[f]["time"].get<double>(), file.result.times[f]);
    lowest = std::min(lowest, frames[f]["position_error"].get<double>());
    highest = std::max(highest, frames[f]["position_error"].get<double>());
  }
  EXPECT_LE(lowest, errors["position_error"].get<double>() * (1 + 1e-12));
  EXPECT_GE(highest, errors["position_error"].get<double>() * (1 - 1e-12));
}

TEST_F(RolloutBatchApi, BadRequestsAreRefused) {
  const auto rom = ReducedModel::load(model_path(), scene_path(), settings());
  EXPECT_THROW(rom.batch({}), std::runtime_error);            // no rollouts
  EXPECT_THROW(rom.batch({{1.0, 2.0}}), std::runtime_error);  // two values for one parameter
  const auto batch = rom.batch({{1.0}});
  EXPECT_THROW(batch.decode(1, rom.reference_points()), std::out_of_range);
  EXPECT_THROW(batch.decode(0, {0.0, 0.0}), std::invalid_argument);  // not (n, 3)
  // Greedy selection takes its samples from the model's ranking: a model without one is refused.
  RomSettings greedy = settings();
  greedy.selection = SampleSelection::Greedy;
  try {
    ReducedModel::load(unranked_model_path(), scene_path(), greedy);
    ADD_FAILURE() << "a model without a sample ranking was accepted for greedy selection";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("stores no sample ranking"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReducedModel::load(model_path() + ".missing", scene_path(), settings()), std::runtime_error);
}

}  // namespace
}  // namespace mpmrom::test
