// What keeps the reduced model's memory bounded on large bodies: the offline fits' probing steppers build node sets
// over the training states they probe, not the whole training motion (rom/snapshots.cpp), and decoding runs a few codes
// a pass (rom/decode.cpp), each the same as the unbounded way; and how many training states the fits probe.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <string>
#include <vector>

#include "mpmrom/rom.hpp"
#include "rollout_batch_fixture.hpp"
#include "rom/detail/decoder.hpp"
#include "rom/detail/rollout_driver.hpp"
#include "rom/detail/snapshots.hpp"

namespace mpmrom::test {
namespace {

// A pushed block whose pushes carry it several cells (up to 0.46 m on a 10 cm grid) by its middle frame (two training
// runs, the middle push the test run), and a small network trained on it, once for the file.
class RomLargeBodies : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mpmrom-test-large-bodies-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(scene_path()) << pushed_block_scene("pushed_block", 0.04, 4, 0.4, {8000.0, 12000.0, 10000.0}, 2);
    sweep_and_train_small_model(scene_path(), dir_, (dir_ / "model.h5").string());
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string scene_path() { return (dir_ / "scene.toml").string(); }
  // the weights as stored, in the build's precision
  static Model model() { return load_model((dir_ / "model.h5").string()); }
  static inline fs::path dir_;
};

// The grid step's probe from a training state (the Galerkin fits' target) with node sets built over the probed codes
// alone (the state's code and its neighbours in time) gives what it gives over every training code: the sets are
// smaller, and every node and source the sub-step reads is in both, so the velocities it hands back are the same
// bitwise (a source outside the smaller sets lies beyond its stencil and adds exact zeros to the larger sets'
// sums). The pushes carry the block several cells by the middle frame, so sets over another frame's codes would not
// hold the probe (checked: over the first frame's code alone the velocities differ; at a displacement of 1.5 cells
// they did not).
TEST_F(RomLargeBodies, GridProbeOverTheProbedCodesIsTheProbeOverEveryCode) {
  const Model model = RomLargeBodies::model();
  const Scene scene = load_scene(scene_path());
  RomSettings grid;
  grid.method = RomMethod::MaterialPoint;
  grid.weighting = SampleWeighting::Mass;
  std::vector<int> indices;
  const auto cases = impl::trained_cases(model, scene, 1, indices);
  ASSERT_EQ(cases.size(), 1u);
  std::vector<int> every(model.num_points());
  std::iota(every.begin(), every.end(), 0);
  const int frames = scene.num_outputs + 1, frame = frames / 2;
  const std::vector<std::size_t> run = impl::codes_of_run(model, indices[0]);
  ASSERT_EQ(run.size(), std::size_t(frames));
  const std::vector<int> probed = {int(run[frame - 1]), int(run[frame]), int(run[frame + 1])};
  const HyperReduction over_every = build_hyper_reduction(model, scene, grid, every);
  const HyperReduction over_probed = build_hyper_reduction(model, scene, grid, every, probed);
  EXPECT_LT(over_probed.node_sources.size(), over_every.node_sources.size());  // the point of it
  std::vector<std::vector<double>> velocities;
  for (const HyperReduction* reduction : {&over_every, &over_probed}) {
    auto stepper = impl::create_stepper(model, scene_path(), scene.design.names, cases, grid, *reduction);
    impl::BatchState state = stepper->state();
    state.frame = frame;
    impl::training_state(model, indices, frame, frames, state.xhat, state.xhatdot);
    stepper->restore(state);
    ASSERT_GT(stepper->probe_substep(), 0.0);
    EXPECT_EQ(stepper->flags(0), 0);
    velocities.push_back(stepper->last_projection_inputs().velocity);
  }
  ASSERT_EQ(velocities[0].size(), 3 * model.num_points());
  EXPECT_EQ(velocities[1], velocities[0]);
}

// Decoding a code a pass gives the fields of decoding every code in one pass, bit for bit: the network's value at
// one point for one code does not depend on the others in its pass.
TEST_F(RomLargeBodies, DecodingInPassesIsDecodingAtOnce) {
  const Model model = RomLargeBodies::model();
  const std::size_t r = std::size_t(model.latent_dim), frames = model.num_codes() / 2;
  const std::vector<double> codes(model.codes.begin(), model.codes.begin() + std::ptrdiff_t(frames * r));
  std::vector<double> rates(codes.size());
  for (std::size_t i = 0; i < rates.size(); ++i) rates[i] = 0.1 * double(i % 7) - 0.3;
  const DecodedFields at_once = impl::decode_in_passes(model, model.X, codes, rates, std::size_t(1) << 30);
  const DecodedFields code_by_code = impl::decode_in_passes(model, model.X, codes, rates, 1);
  ASSERT_EQ(at_once.x.size(), frames * 3 * model.num_points());
  EXPECT_EQ(code_by_code.x, at_once.x);
  EXPECT_EQ(code_by_code.v, at_once.v);
  EXPECT_EQ(code_by_code.F, at_once.F);
  EXPECT_EQ(decode(model, model.X, codes, rates).v, at_once.v);
}

// The Galerkin fits' training states: --cubature-runs training runs (at most the design's) at --cubature-frames inner
// output frames each (at most the run's), one snapshot a state, each tagged with its run.
TEST_F(RomLargeBodies, TrainingStatesAreTheRunsTimesTheFramesAsked) {
  const Model model = RomLargeBodies::model();
  const Scene scene = load_scene(scene_path());
  const int inner = scene.num_outputs - 1;  // the frames with a code on both sides
  ASSERT_GE(inner, 3);
  RomSettings settings = rom_defaults(RomMethod::Galerkin);
  settings.snapshot_source = SnapshotSource::States;
  const auto count = [&](int runs, int frames) {
    settings.cubature_runs = runs;
    settings.cubature_frames = frames;
    settings.validate();
    std::vector<int> per_run(2, 0);
    impl::snapshot_stream(model, cubature_snapshots(scene, settings, nullptr))([&](const impl::PointSnapshot& s) {
      ASSERT_TRUE(s.run == 0 || s.run == 1);
      ++per_run[std::size_t(s.run)];
    });
    return per_run;
  };
  EXPECT_EQ(count(1, 2), (std::vector<int>{2, 0}));
  EXPECT_EQ(count(2, 1), (std::vector<int>{1, 1}));
  EXPECT_EQ(count(8, 64), (std::vector<int>{inner, inner}));  // the scene's 2 training runs, each inner frame once
  settings.cubature_frames = 0;
  EXPECT_THROW(settings.validate(), std::invalid_argument);
}

// The greedy projection fits the rollout's own all-point step: from the same training state, Algorithm 2's
// snapshot holds its quadrature transfers' velocity increments, not Algorithm 1's particle transfers'. Both hand the
// same state's grid motion to the same rows, so they differ, by more than rounding (1e-6 of their size: another
// transfer, not another summation order), and by less than their size (the same motion, other quadrature).
TEST_F(RomLargeBodies, EachGridMethodSnapshotsItsOwnStep) {
  const Model model = RomLargeBodies::model();
  const Scene scene = load_scene(scene_path());
  const auto first_increments = [&](RomMethod method) {
    RomSettings settings = rom_defaults(method);
    settings.snapshot_source = SnapshotSource::States;
    settings.cubature_runs = 1;
    settings.cubature_frames = 1;
    std::vector<double> increments;
    impl::snapshot_stream(model, cubature_snapshots(scene, settings, nullptr))([&](const impl::PointSnapshot& s) {
      if (increments.empty()) increments.assign(s.fields.at(0), s.fields.at(0) + 3 * s.rows(model.num_points()));
    });
    return increments;
  };
  const std::vector<double> point = first_increments(RomMethod::MaterialPoint);
  const std::vector<double> node = first_increments(RomMethod::SampleNode);
  ASSERT_EQ(point.size(), 3 * model.num_points());
  ASSERT_EQ(node.size(), point.size());
  double difference = 0, size = 0;
  for (std::size_t i = 0; i < point.size(); ++i) {
    difference += (node[i] - point[i]) * (node[i] - point[i]);
    size += point[i] * point[i];
  }
  ASSERT_GT(size, 0);
  EXPECT_GT(std::sqrt(difference / size), 1e-6);
  EXPECT_LT(std::sqrt(difference / size), 1.0);
}

}  // namespace
}  // namespace mpmrom::test
