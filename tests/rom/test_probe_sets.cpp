// The offline fits' probing steppers (rom/snapshots.cpp): their node sets cover the training states they probe, not
// the whole training motion.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <numeric>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "manifold/trainer.hpp"
#include "mpmrom/rom.hpp"
#include "mpmrom/training_data.hpp"
#include "rom/detail/rollout_driver.hpp"
#include "rom/detail/snapshots.hpp"
#include "snapshots/simulate.hpp"

namespace mpmrom::test {
namespace {

namespace fs = std::filesystem;

// The grid step's probe from a training state (the Galerkin fits' target) with node sets built over the probed codes
// alone (the state's code and its neighbours in time) gives what it gives over every training code: the sets are
// smaller, and every node and source the sub-step reads is in both, so the velocities it hands back are the same
// bitwise (a source outside the smaller sets lies beyond its stencil and adds exact zeros to the larger sets'
// sums). The pushes carry the block several cells (up to 0.46 m on a 10 cm grid) by the middle frame, so sets over
// another frame's codes would not hold the probe (checked: over the first frame's code alone the velocities differ;
// at a displacement of 1.5 cells they did not).
TEST(RomProbeSets, GridProbeOverTheProbedCodesIsTheProbeOverEveryCode) {
  const fs::path dir = fs::temp_directory_path() / ("mpmrom-test-probe-sets-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string scene_path = (dir / "scene.toml").string();
  std::ofstream(scene_path) << pushed_block_scene("pushed_block", 0.04, 4, 0.4, {8000.0, 12000.0}, 1);
  sweep(scene_path, (dir / "sweep").string(), default_p2g_strategy());
  TrainingSettings training;
  training.latent_dim = 2;
  training.width = 8;
  training.depth = 3;
  training.epochs = 30;
  const auto data = load_training_data({(dir / "sweep").string()});
  save_model((dir / "model.h5").string(), train_model(data, training, "", false));
  const Model model = load_model((dir / "model.h5").string());  // the weights as stored, in the build's precision
  const Scene scene = load_scene(scene_path);

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
    auto stepper = impl::create_stepper(model, scene_path, scene.design.names, cases, grid, *reduction);
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
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mpmrom::test
