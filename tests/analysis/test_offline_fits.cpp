// The offline fits of the hyper-reduction through the library's API: the cubature (ECSW) selection and weights, the
// Galerkin step's weights fitted to the grid step's force, their held-out misfits, the training-state snapshots and
// the greedy projection selection, on the fixture's small trained model.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numeric>
#include <set>
#include <string>
#include <vector>

#include "mpmrom/mpmrom_config.hpp"  // real_t
#include "rollout_batch_fixture.hpp"
#include "rom/rom_file.hpp"
#include "analysis/evaluation.hpp"

namespace mpmrom::test {
namespace {

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
  // --cfl caps the Galerkin step's time step up to 100 (its reduced dynamics bound it), the grid methods' up to 10
  RomSettings long_step = reduced.settings;
  long_step.cfl = 100;
  long_step.validate();
  long_step.cfl = 101;
  EXPECT_THROW(long_step.validate(), std::invalid_argument);
  RomSettings grid_long_step;
  grid_long_step.cfl = 11;
  EXPECT_THROW(grid_long_step.validate(), std::invalid_argument);
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

// The Galerkin step's force target over the training states is the grid step's force summed over the whole body,
// whatever the candidates: on a body of more points than the candidates the same samples' force weights fit the same
// target as over every point, so the force block's misfit is the same (the samples' own forces are the same at the
// same points), to rounding: over every point v_n is the kernel's (real_t), over the candidates the host's J (double)
// times the rate, and the force divides v_G2P - v_n, a small part of v, by dt, which amplifies the kernel's rounding
// (float: 1.4e-9 measured; 100 eps of real_t allowed, 1e-9 at least), while the mass and momentum
// blocks, whose targets the candidates stand in for, may differ. (Summed over the candidates alone, as before, the
// force misfits differed by 0.04 here: 0.085 against 0.126.)
TEST_F(RolloutBatchApi, GridForceTargetIsTheWholeBodysWhateverTheCandidates) {
  const Model model = load_model(model_path());
  CubatureSnapshots every;
  every.scene_path = scene_path();
  every.count = 2;
  every.settings = rom_defaults(RomMethod::Galerkin);
  every.max_candidates = model.num_points();
  CubatureSnapshots fewer = every;
  fewer.max_candidates = model.num_points() / 4;
  const CubatureFit chosen = cubature_selection(model, fewer, 4);  // samples among the fewer candidates
  ASSERT_FALSE(chosen.samples.empty());
  const CubatureFit over_every = cubature_weights(model, every, chosen.samples);
  const CubatureFit over_fewer = cubature_weights(model, fewer, chosen.samples);
  ASSERT_EQ(over_every.misfits.size(), 3u);
  ASSERT_EQ(over_fewer.misfits.size(), 3u);
  EXPECT_GT(over_every.misfits[2], 1e-6);  // not trivially fitted: the comparison means something
  EXPECT_NEAR(over_fewer.misfits[2], over_every.misfits[2],
              std::max(1e-9, 100 * double(std::numeric_limits<real_t>::epsilon())));
}

// The Galerkin step's time step stays within its reduced dynamics' bound (1 / omega, omega the highest frequency over
// the training states) whatever the CFL number asks: at a CFL number whose step would be the whole output interval,
// each interval takes exactly ceil(interval / bound) equal sub-steps, and no rollout stops. The bound is positive and
// finite, and Algorithms 1 and 2 have none.
TEST_F(RolloutBatchApi, GalerkinStepKeepsWithinItsReducedDynamicsBound) {
  const Model model = load_model(model_path());
  const Scene scene = load_scene(scene_path());
  RomSettings galerkin = rom_defaults(RomMethod::Galerkin);
  galerkin.samples = 4;
  galerkin.cfl = 10;  // the largest taken
  const HyperReduction reduction = prepare_hyper_reduction(model, scene, galerkin, nullptr, {}, {});
  ASSERT_GT(reduction.stable_time_step, 0);
  ASSERT_TRUE(std::isfinite(reduction.stable_time_step));
  const RomResult result =
      run_rollouts(model, scene_path(), scene.design.names, {{{1.0}, "test"}}, galerkin, reduction);
  EXPECT_TRUE(result.outcomes[0].message.empty()) << result.outcomes[0].message;  // stopped: a message
  long expected = 0;
  for (std::size_t f = 1; f < result.times.size(); ++f)
    expected += long(std::ceil((result.times[f] - result.times[f - 1]) / reduction.stable_time_step - 1e-9));
  EXPECT_EQ(result.steps, expected);
  EXPECT_GT(expected, long(result.times.size()) - 1);  // the bound, not the CFL number, set the step
  RomSettings point;
  point.samples = 4;
  point.selection = SampleSelection::Random;
  EXPECT_EQ(prepare_hyper_reduction(model, scene, point, nullptr, {}, {}).stable_time_step, 0.0);
}

// The points a rollout's sub-step evaluates the network at (RomResult::evaluated_points): Algorithm 1's sources, the
// samples and their co-moving neighbours; the Galerkin step's samples and the distinct nodes of their quadratic
// B-spline stencils in the reference configuration (its grid strain), counted here from the stencils' base nodes.
TEST_F(RolloutBatchApi, EvaluatedPointsAreTheSourcesOrTheSamplesAndTheirStencilNodes) {
  const Model model = load_model(model_path());
  const Scene scene = load_scene(scene_path());
  const std::vector<int> samples = {0, 21, 42, 63};
  RomSettings galerkin = rom_defaults(RomMethod::Galerkin);
  galerkin.samples = int(samples.size());
  RomSettings point;
  point.samples = int(samples.size());
  point.weighting = SampleWeighting::Mass;
  std::set<std::array<int, 3>> nodes;
  for (const int p : samples) {
    int base[3];
    for (int d = 0; d < 3; ++d)
      base[d] = int(std::floor((model.X[3 * std::size_t(p) + std::size_t(d)] - scene.domain.lo[d]) / scene.dx - 0.5));
    for (int a = 0; a < 27; ++a) nodes.insert({base[0] + a / 9, base[1] + a / 3 % 3, base[2] + a % 3});
  }
  const std::vector<RolloutCase> one = {{{1.0}, "test"}};
  const HyperReduction on_grid = build_hyper_reduction(model, scene, point, samples);
  EXPECT_EQ(run_rollouts(model, scene_path(), scene.design.names, one, point, on_grid).evaluated_points,
            on_grid.source_points.size());
  EXPECT_GT(on_grid.source_points.size(), samples.size());
  HyperReduction cubature = build_hyper_reduction(model, scene, galerkin, samples);
  cubature.stable_time_step = 1e-3;  // the bound's probes are not what this counts
  EXPECT_EQ(run_rollouts(model, scene_path(), scene.design.names, one, galerkin, cubature).evaluated_points,
            samples.size() + nodes.size());
  EXPECT_LT(nodes.size(), 27 * samples.size());  // stencils that share nodes count them once
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

}  // namespace
}  // namespace mpmrom::test
