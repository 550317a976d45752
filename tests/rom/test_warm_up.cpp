// A rollout's set-up runs one sub-step and returns to its state (BatchStepperBase::warm_up, which keeps the kernels'
// first launches out of the step time): the rollouts must be those of a batch stepped without it, bit for bit.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "mpmrom/rom.hpp"
#include "rollout_batch_fixture.hpp"
#include "rom/detail/rollout_driver.hpp"

namespace mpmrom::test {
namespace {

TEST_F(RolloutBatchApi, WarmingUpLeavesTheRolloutsAsTheyWere) {
  const Model model = load_model(model_path());
  const Scene scene = load_scene(scene_path());
  const std::vector<RolloutCase> cases{{{0.75}, ""}, {{1.5}, ""}};
  for (const RomMethod method : {RomMethod::MaterialPoint, RomMethod::SampleNode, RomMethod::Galerkin}) {
    RomSettings s = rom_defaults(method);
    s.samples = 8;
    s.selection = SampleSelection::Random;  // no offline fit: what is tested is the stepper
    const HyperReduction reduction = prepare_hyper_reduction(model, scene, s, nullptr, {});
    RomResult plain, warmed;
    for (RomResult* result : {&plain, &warmed}) {
      const auto stepper = impl::create_stepper(model, scene_path(), {"push"}, cases, s, reduction);
      if (result == &warmed) stepper->warm_up();
      impl::record_rollouts(*stepper, *result, {});
    }
    const std::string label = to_string(method);
    EXPECT_GT(plain.steps, 0) << label;
    EXPECT_EQ(warmed.xhat, plain.xhat) << label;
    EXPECT_EQ(warmed.xhatdot, plain.xhatdot) << label;
    EXPECT_EQ(warmed.steps, plain.steps) << label;
    ASSERT_EQ(warmed.outcomes.size(), cases.size()) << label;
    for (std::size_t b = 0; b < cases.size(); ++b) {
      EXPECT_EQ(warmed.outcomes[b].flags, plain.outcomes[b].flags) << label;
      EXPECT_EQ(warmed.outcomes[b].frames_completed, plain.outcomes[b].frames_completed) << label;
      EXPECT_EQ(warmed.outcomes[b].max_condition, plain.outcomes[b].max_condition) << label;
      EXPECT_EQ(warmed.outcomes[b].regularized_steps, plain.outcomes[b].regularized_steps) << label;
    }
  }
}

}  // namespace
}  // namespace mpmrom::test
