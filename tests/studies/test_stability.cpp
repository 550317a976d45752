// The full-order model's detectors and safeguards (docs/stability.md): each constructed failure stops the run in the
// step where it happens with the documented cause, never a NaN in the output; the energy budget holds in a stable
// run; the max_cfl safeguard turns a run past the stability limit into a stable one; a failed simulation keeps its
// frames in a file that says so.
#include <gtest/gtest.h>

#include <Kokkos_Core.hpp>

#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>

#include "fixtures.hpp"
#include "fom/fom.hpp"
#include "io/hdf5_file.hpp"
#include "snapshots/simulate.hpp"
#include "mpmrom/snapshot.hpp"
#include "studies/detail/study_runner.hpp"
#include "studies/stability.hpp"

#include <unistd.h>

namespace mpmrom::test {
namespace {

// A spinning block of soft solid, free in space: P-wave speed 11.6 m/s, so the CFL step is 4.3 ms at cfl = 1.
Scene spinning_block(double cfl, const std::vector<std::string>& more_overrides = {}) {
  std::vector<std::string> overrides = {"time.cfl=" + std::to_string(cfl)};
  overrides.insert(overrides.end(), more_overrides.begin(), more_overrides.end());
  return fixture_scene("spinning_block.toml", overrides);
}

// Runs to the end; returns the failure, if any.
std::optional<SimulationFailure> run_to_end(FomSolver& solver, const Scene& scene) {
  try {
    for (int k = 1; k <= scene.num_outputs; ++k) solver.advance_to(scene.end_time * k / scene.num_outputs);
  } catch (const SimulationFailure& failure) {
    return failure;
  }
  return std::nullopt;
}

// Sets one component of one particle's field on the device, as a corrupted state would.
template <class View>
void poke_value(const View& view, int p, int i, int j, real_t value) {
  auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), view);
  if constexpr (View::rank == 2)
    host(p, i) = value;
  else
    host(p, i, j) = value;
  Kokkos::deep_copy(view, host);
}

// The spinning block with one value of its state spoiled at t = 0.01 s (`spoil` takes the particles), run to the end:
// it must stop with `cause`, its message naming `words`; at the step after the spoiling where `next_step`.
template <class Spoil>
void expect_stopped(Spoil&& spoil, FomFailureCause cause, const std::string& words, bool next_step) {
  const Scene scene = spinning_block(0.3);
  FomSolver solver(scene);
  solver.advance_to(0.01);
  const long steps_before = solver.steps();
  spoil(solver.particles());
  const auto failure = run_to_end(solver, scene);
  ASSERT_TRUE(failure.has_value());
  EXPECT_EQ(failure->cause(), cause);
  if (next_step) EXPECT_EQ(failure->step(), steps_before + 1);
  EXPECT_NE(std::string(failure->what()).find(words), std::string::npos) << failure->what();
}

TEST(FomDetectors, NonFiniteVelocityStopsTheStepItAppearsIn) {
  const auto nan = std::numeric_limits<real_t>::quiet_NaN();
  expect_stopped([&](const auto& particles) { poke_value(particles.v, 17, 1, 0, nan); }, FomFailureCause::NotFinite,
                 "non-finite", true);
}

TEST(FomDetectors, InvertedDeformationGradientStopsTheStepItAppearsIn) {
  // F = diag(1, 1, -1): a mirrored point, det F = -1
  expect_stopped([](const auto& particles) { poke_value(particles.F, 5, 2, 2, real_t(-1)); }, FomFailureCause::Inverted,
                 "det F <= 0", true);
}

TEST(FomDetectors, MaterialOutsideTheGridStopsTheRun) {
  // 1.5 m beyond the grid's +x face
  expect_stopped([](const auto& particles) { poke_value(particles.x, 3, 0, 0, real_t(2.0)); },
                 FomFailureCause::LeftGrid, "left the grid", false);
}

// Past the stability limit (cfl 1.5) the energy grows geometrically: the budget check stops the run long before the
// fields overflow, and the same run with the max_cfl safeguard completes inside its budget.
TEST(FomDetectors, EnergyBlowUpPastTheStabilityLimitAndTheSubSteppingSafeguard) {
  const Scene unstable = spinning_block(1.5);
  FomSolver solver(unstable);
  const auto failure = run_to_end(solver, unstable);
  ASSERT_TRUE(failure.has_value());
  EXPECT_EQ(failure->cause(), FomFailureCause::EnergyBlowUp) << failure->what();
  EXPECT_NE(std::string(failure->what()).find("exceeds 10"), std::string::npos) << failure->what();

  const Scene guarded = spinning_block(1.5, {"time.max_cfl=0.5"});
  FomSolver safe(guarded);
  const auto none = run_to_end(safe, guarded);
  EXPECT_FALSE(none.has_value()) << none->what();
  EXPECT_GT(safe.safeguarded_steps(), 0);
  EXPECT_LE(safe.energy().total(), safe.energy_budget());

  // A fixed dt past the limit is shortened by the safeguard in the same way.
  const Scene fixed = spinning_block(0.3, {"time.dt=0.01", "time.max_cfl=0.5"});
  FomSolver fixed_safe(fixed);
  EXPECT_FALSE(run_to_end(fixed_safe, fixed).has_value());
  EXPECT_GT(fixed_safe.safeguarded_steps(), 0);
}

TEST(SimulateFailure, KeepsTheFramesBeforeTheFailureUnderAFailedName) {
  const auto dir = std::filesystem::temp_directory_path() / ("mpmrom_test_stability_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string out = (dir / "run.h5").string();
  const Scene unstable = spinning_block(1.5);
  try {
    simulate(unstable, out, P2GStrategy::Atomic);
    FAIL() << "the run past the stability limit completed";
  } catch (const SimulationFailure& failure) {
    EXPECT_EQ(failure.cause(), FomFailureCause::EnergyBlowUp);
    EXPECT_NE(std::string(failure.what()).find("run.failed.h5"), std::string::npos) << failure.what();
  }
  EXPECT_FALSE(std::filesystem::exists(out));  // nothing under the name of a finished run
  const std::string kept = failed_path_for(out);
  ASSERT_TRUE(std::filesystem::exists(kept));
  EXPECT_TRUE(std::filesystem::exists(dir / "run.failed.xmf"));
  const hdf5::File file = hdf5::File::open(kept);
  EXPECT_EQ(file.integer_attribute("complete"), 0);
  EXPECT_NE(file.string_attribute("failure").find("energy"), std::string::npos);
  // Readers refuse it as a finished run, naming the failure.
  try {
    read_snapshot(kept);
    FAIL() << "a failed run's file was read as a finished run";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("a run that failed"), std::string::npos) << error.what();
  }
  std::filesystem::remove_all(dir);
}

// The map's three verdicts: a detector outranks any error; a run that finished is judged by its error alone.
TEST(StabilityMap, ClassifiesStoppedInaccurateAndStableRuns) {
  EXPECT_EQ(classify(true, 0.001, 0.05), "unstable");
  EXPECT_EQ(classify(false, 0.06, 0.05), "inaccurate");
  EXPECT_EQ(classify(false, std::nan(""), 0.05), "inaccurate");
  EXPECT_EQ(classify(false, 0.05, 0.05), "stable");
}

// Without --selection the map's hyper-reduced configurations are each method's rollout without flags (docs/rom.md
// "Defaults": Algorithm 1's stored greedy projection set, Algorithm 2's samples fitted to its own step); a selection
// given applies to both methods and changes nothing else.
TEST(StabilityMap, HyperReducedConfigurationsAreTheRolloutsDefaults) {
  EXPECT_FALSE(StabilitySettings{}.selection.has_value());
  const std::string scene = fixture_path("spinning_block.toml");
  const StudyRunner defaults(scene, StabilitySettings{}.selection);
  const StudyRunner greedy(scene, SampleSelection::Greedy);
  for (const RomMethod method : {RomMethod::MaterialPoint, RomMethod::SampleNode}) {
    RomSettings expected = rom_defaults(method);
    expected.samples = 15;
    expected.cfl = 3;
    EXPECT_EQ(defaults.rom_settings(method, 15, 3).to_json(), expected.to_json()) << to_string(method);
    expected.selection = SampleSelection::Greedy;
    EXPECT_EQ(greedy.rom_settings(method, 15, 3).to_json(), expected.to_json()) << to_string(method);
  }
}

}  // namespace
}  // namespace mpmrom::test
