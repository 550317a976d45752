// The greedy projection's trial sets (rom/detail/selection_trials.hpp): a set for each weight of the increments'
// response to the latent state, of which the rollout keeps the one whose rollouts over the training runs stay closest
// to the model's codes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "mpmrom/rom.hpp"
#include "rollout_batch_fixture.hpp"
#include "rom/detail/selection_trials.hpp"

namespace mpmrom::test {
namespace {

// The responses enter the snapshots without changing the increments: at weight 0 the set is the one chosen on
// snapshots without them, bit for bit (the reduced motion is continued from each frame's state after the probes).
// Each trial set's rollouts are scored against the model's codes, and the tried set is the lowest-scored one's.
TEST_F(RolloutBatchApi, TrialSetsKeepTheSetWhoseTrainingRolloutsStayClosest) {
  const Model model = load_model(model_path());
  const Scene scene = load_scene(scene_path());
  RomSettings s = settings();
  s.selection_sensitivities = {0, 0.3, 3};
  ASSERT_EQ(fitted_weights(s), SampleWeighting::Cubature);
  const std::size_t count = std::size_t(s.samples);
  const ProjectionSelector selector(model, cubature_snapshots(scene, s, nullptr));
  RomSettings alone = s;
  alone.selection_sensitivities = {0};
  CubatureSnapshots without = cubature_snapshots(scene, alone, nullptr);
  without.settings.weighting = SampleWeighting::Cubature;
  const CubatureFit increments = greedy_projection_selection(model, without, count);
  const CubatureFit at_zero = selector.select(count, true, 0);
  EXPECT_EQ(at_zero.samples, increments.samples);
  EXPECT_EQ(at_zero.weights, increments.weights);
  EXPECT_EQ(at_zero.misfits, increments.misfits);

  std::vector<CubatureFit> sets;
  std::vector<double> errors;
  for (const double w : s.selection_sensitivities) {
    sets.push_back(selector.select(count, true, w));
    ASSERT_EQ(sets.back().samples.size(), count);
    errors.push_back(impl::training_rollout_error(model, scene, s, sets.back()));
    EXPECT_GT(errors.back(), 0.0) << w;
    EXPECT_TRUE(std::isfinite(errors.back())) << w;  // the fixture's motion holds with any of these sets
  }
  std::vector<std::string> lines;
  const CubatureFit tried =
      impl::tried_projection_set(model, scene, s, selector, true, [&](const std::string& l) { lines.push_back(l); });
  const std::size_t best = std::size_t(std::min_element(errors.begin(), errors.end()) - errors.begin());
  EXPECT_EQ(tried.samples, sets[best].samples);
  EXPECT_EQ(tried.weights, sets[best].weights);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_NE(lines[0].find("3 trial sets"), std::string::npos) << lines[0];

  // A rollout that stops scores infinite: with every rollout stopped at once, the first set is kept.
  RomSettings stopping = s;
  stopping.energy_growth = 1e-9;
  EXPECT_EQ(impl::training_rollout_error(model, scene, stopping, sets[1]), std::numeric_limits<double>::infinity());
  EXPECT_EQ(impl::tried_projection_set(model, scene, stopping, selector, true, {}).samples, sets[0].samples);
  // One weight: its set, with no rollouts.
  EXPECT_EQ(impl::tried_projection_set(model, scene, alone, selector, true, {}).samples, at_zero.samples);
  // A scene of twice the output times: the model holds no codes at half of them, so no rollout is scored and the
  // first set is kept, with a line saying why.
  const std::string finer = (dir_ / "finer_outputs.toml").string();
  std::ofstream(finer) << pushed_block_scene("pushed_block", 0.04, 8, 0.4, {0.5, 1.0, 1.5}, 1);
  lines.clear();
  const CubatureFit first = impl::tried_projection_set(model, load_scene(finer), s, selector, true,
                                                       [&](const std::string& l) { lines.push_back(l); });
  EXPECT_EQ(first.samples, sets[0].samples);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_NE(lines[0].find("kept the first"), std::string::npos) << lines[0];
}

}  // namespace
}  // namespace mpmrom::test
