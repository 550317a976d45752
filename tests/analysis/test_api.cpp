// The deployment API (rollout_batch.hpp) against the batch driver the command line uses: a batch advanced output
// interval by output interval reproduces run_rollouts bit for bit (same kernels, same order, same backend), decodes
// to the same fields, and refuses bad requests with a clear error; a model trained from the fixture's sweep read at
// some of its points keeps the whole body.
#include <gtest/gtest.h>

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numeric>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rollout_batch_fixture.hpp"
#include "rom/rom_file.hpp"
#include "analysis/evaluation.hpp"

namespace mpmrom::test {
namespace {

bool host_space_is_default() {
  return Kokkos::SpaceAccessibility<Kokkos::HostSpace, Kokkos::DefaultExecutionSpace::memory_space>::accessible;
}

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

TEST_F(RolloutBatchApi, EveryRolloutDecodedAtOnceAndDeviceCopiesMatchTheHostCalls) {
  const auto rom = ReducedModel::load(model_path(), scene_path(), settings());
  auto batch = rom.batch({{0.5}, {1.25}, {1.5}});
  batch.advance();
  std::vector<double> X;
  for (std::size_t i = 0; i < rom.reference_points().size(); i += 3 * 5)  // every fifth point
    X.insert(X.end(), rom.reference_points().begin() + long(i), rom.reference_points().begin() + long(i) + 3);
  const std::size_t n = X.size() / 3;
  const DecodedFields every = batch.decode_all(X);
  ASSERT_EQ(every.x.size(), 3 * n * 3);
  ASSERT_EQ(every.F.size(), 3 * n * 9);
  for (int b = 0; b < 3; ++b) {
    // Each (rollout, point) is the same network evaluation in one pass or in three: equal to the last bit.
    const DecodedFields alone = batch.decode(b, X);
    EXPECT_TRUE(std::equal(alone.x.begin(), alone.x.end(), every.x.begin() + long(b * n * 3)));
    EXPECT_TRUE(std::equal(alone.v.begin(), alone.v.end(), every.v.begin() + long(b * n * 3)));
    EXPECT_TRUE(std::equal(alone.F.begin(), alone.F.end(), every.F.begin() + long(b * n * 9)));
  }

  const DeviceArray state = batch.latent_state_on_device(), rate = batch.latent_rate_on_device();
  const auto host_state = batch.latent_state(), host_rate = batch.latent_rate();
  batch.advance();  // a copy: later steps leave it as it was
  for (const auto& [array, host] : {std::pair{&state, &host_state}, std::pair{&rate, &host_rate}}) {
    ASSERT_EQ(array->shape, (std::vector<std::int64_t>{3, batch.latent_dim()}));
    EXPECT_EQ(array->bits, int(8 * sizeof(real_t)));
    EXPECT_EQ(array->dlpack_device_type, host_space_is_default() ? 1 : 2);
    ASSERT_TRUE(array->owner);
    using Device = Kokkos::View<const real_t*, Kokkos::DefaultExecutionSpace::memory_space, Kokkos::MemoryUnmanaged>;
    const Device on_device(static_cast<const real_t*>(array->data), host->size());
    const auto copied = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), on_device);
    for (std::size_t i = 0; i < host->size(); ++i) EXPECT_EQ(double(copied(i)), (*host)[i]) << i;
  }
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

// Training runs read at some points (max_points): the same sorted points in every training run, the test runs whole,
// the whole reference kept; a model trained on them holds every point, and its greedy ranking names the model's
// points. At or above the runs' count nothing is left out.
TEST_F(RolloutBatchApi, TrainingAtSomePointsKeepsTheWholeBody) {
  const auto whole = load_training_data({(dir_ / "sweep").string()});
  const std::size_t P = whole.train.runs.front().num_points, kept = P / 3;
  const auto data = load_training_data({(dir_ / "sweep").string()}, {}, SnapshotFields::WithoutAffine, kept, 5);
  const auto& ids = data.train.runs.front().point_ids;
  ASSERT_EQ(ids.size(), kept);
  EXPECT_TRUE(std::is_sorted(ids.begin(), ids.end()));
  EXPECT_EQ(std::adjacent_find(ids.begin(), ids.end()), ids.end());
  EXPECT_LT(ids.back(), P);
  for (const auto& run : data.train.runs) {
    EXPECT_EQ(run.point_ids, ids);
    EXPECT_EQ(run.num_points, kept);
  }
  for (const auto& run : data.test.runs) EXPECT_EQ(run.num_points, P);
  EXPECT_EQ(data.reference.X, whole.train.runs.front().X);
  EXPECT_EQ(data.reference.mass, whole.train.runs.front().mass);

  TrainingSettings settings;
  settings.latent_dim = 2;
  settings.width = 8;
  settings.depth = 3;
  settings.epochs = 10;
  settings.max_points = int(kept);
  const Model model = train_model(data, settings, "", false);
  EXPECT_EQ(model.num_points(), P);
  EXPECT_EQ(model.X, whole.train.runs.front().X);
  EXPECT_TRUE(std::isfinite(model.errors["test"]["position_error"].get<double>()));
  for (const auto p : rank_samples_greedily(model, data, 10)) EXPECT_LT(std::size_t(p), P);

  const auto all = load_training_data({(dir_ / "sweep").string()}, {}, SnapshotFields::WithoutAffine, P, 5);
  EXPECT_TRUE(all.train.runs.front().point_ids.empty());
  EXPECT_TRUE(all.reference.X.empty());
}

// The default hyper-reduction: the set `mpmrom train --scene` stores is the greedy projection selection with fitted
// weights (the same deterministic computation), a rollout of that count uses it as stored (its weights, or the
// masses with --weights mass), and another count, another list of trial sets, or a model without a stored set, is
// fitted at set-up (with one trial set, the greedy projection selection; the trials are tested in tests/rom), as is
// Algorithm 2's set, on its own step.
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
  s.selection_sensitivities = {0};
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
  s.selection_sensitivities = {0};
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
  prepare_hyper_reduction(model, scene, s, nullptr, {}, count_asks);
  EXPECT_EQ(asked, 2);  // the stored set was chosen among other trial sets: fitted again
  s.selection_sensitivities = settings().selection_sensitivities;
  EXPECT_EQ(prepare_hyper_reduction(model, scene, s, nullptr, {}, count_asks).samples, stored.samples);
  EXPECT_EQ(asked, 2);  // the stored set: no snapshots asked for
  // The stored set is Algorithm 1's: Algorithm 2 asks for snapshots of its own step, also with every other setting
  // the stored set was fitted with.
  RomSettings node = s;
  node.method = RomMethod::SampleNode;
  RomMethod snapshots_of = RomMethod::MaterialPoint;
  std::unique_ptr<ProjectionSelector> own;
  const auto node_asks = [&](const RomSettings& fitted) -> const ProjectionSelector& {
    snapshots_of = fitted.method;
    count_asks(fitted);
    own = std::make_unique<ProjectionSelector>(model, cubature_snapshots(scene, fitted, nullptr));
    return *own;
  };
  prepare_hyper_reduction(model, scene, node, nullptr, {}, node_asks);
  EXPECT_EQ(asked, 3);
  EXPECT_EQ(snapshots_of, RomMethod::SampleNode);
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
  EXPECT_THROW(batch.decode_all({0.0, 0.0}), std::invalid_argument);
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
