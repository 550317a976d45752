// MPI (docs/mpi.md), run under `mpiexec -n 2`: a sweep, a batch of rollouts and a training run shared by the ranks
// against the same work done by one process (rank 0 with MPI_COMM_SELF, same backend and thread count). Sweeps and
// rollouts must be bitwise identical (each run or rollout is computed by the same kernels; the rollouts' shared time
// step makes the shares advance as one batch); training matches within round-off (the gradient sums change order).
// Also the collectives themselves, and a rollout resumed from checkpoints the ranks left at different frames.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "mpmrom/model.hpp"
#include "mpmrom/mpmrom_config.hpp"
#include "core/parallel.hpp"
#include "fixtures.hpp"
#include "mpmrom/rom.hpp"
#include "fom/fom.hpp"
#include "snapshots/simulate.hpp"
#include "mpmrom/snapshot.hpp"
#include "manifold/trainer.hpp"
#include "mpmrom/training_data.hpp"

namespace mpmrom::test {
namespace {

namespace fs = std::filesystem;
using parallel::Communicator;

// Five pushes (an odd count, so the ranks' shares differ in size), one held out; 4 output frames over 0.4 s. A
// softer block than the other tests' (wave speed 1.2 m/s) so that its speed, up to 0.6 m/s, changes how many time
// steps a frame takes (cfl dx over the wave speed plus the fastest sample).
std::string soft_block() {
  const std::string text = pushed_block_scene("pushed_block", 0.4, 4, 0.4, {0.5, 0.75, 1.0, 1.25, 1.5}, 2);
  return parse_scene(text, "pushed_block", {"material.youngs_modulus=1.0e3"}).source_text;
}
const std::string kScene = soft_block();

std::string file_text(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

class Mpi : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const auto world = Communicator::world();
    // one directory for every rank: rank 0's name
    std::string dir = (fs::temp_directory_path() / ("mpmrom-test-mpi-" + std::to_string(::getpid()))).string();
    world.broadcast(dir);
    dir_ = dir;
    if (world.is_root()) {
      fs::remove_all(dir_);
      fs::create_directories(dir_);
      std::ofstream(scene_path()) << kScene;
    }
    world.barrier();
    sweep(scene_path(), (dir_ / "sweep").string(), default_p2g_strategy(), {}, {}, false, world);
    if (world.is_root()) {
      const auto data = load_training_data({(dir_ / "sweep").string()});
      save_model(model_path(), train_model(data, training_settings(), "", false));
    }
    world.barrier();
  }
  static void TearDownTestSuite() {
    Communicator::world().barrier();
    if (Communicator::world().is_root()) fs::remove_all(dir_);
  }
  static std::string scene_path() { return (dir_ / "scene.toml").string(); }
  static std::string model_path() { return (dir_ / "model.h5").string(); }
  static TrainingSettings training_settings() {
    TrainingSettings settings;
    settings.latent_dim = 2;
    settings.width = 8;
    settings.depth = 3;
    settings.epochs = 30;
    settings.batch_snapshots = 4;
    settings.points_per_snapshot = 32;
    return settings;
  }

  static fs::path dir_;
};
fs::path Mpi::dir_;

TEST_F(Mpi, CollectivesCombineEveryRank) {
  const auto world = Communicator::world();
  const int n = world.size(), me = world.rank();
  ASSERT_GE(n, 2) << "run under mpiexec -n 2 or more";
  double values[2] = {double(me), 1.0};
  world.sum(values, 2);
  EXPECT_EQ(values[0], n * (n - 1) / 2.0);
  EXPECT_EQ(values[1], double(n));
  float single = 0.5f;
  world.sum(&single, 1);
  EXPECT_EQ(single, 0.5f * float(n));
  EXPECT_EQ(world.max(double(me)), double(n - 1));
  EXPECT_EQ(world.min(double(me)), 0.0);
  EXPECT_TRUE(world.any(me == n - 1));
  EXPECT_FALSE(world.any(false));

  const auto parts = world.gather(std::string(std::size_t(me) + 1, char('a' + me)));
  if (world.is_root()) {
    ASSERT_EQ(parts.size(), std::size_t(n));
    for (int r = 0; r < n; ++r) EXPECT_EQ(parts[std::size_t(r)], std::string(std::size_t(r) + 1, char('a' + r)));
  } else {
    EXPECT_TRUE(parts.empty());
  }
  std::string text = world.is_root() ? "from rank 0" : "";
  world.broadcast(text);
  EXPECT_EQ(text, "from rank 0");

  // Shares cover every item once, in order, sizes differing by at most one.
  for (const std::size_t count : {0, 1, 5, 7, 1000}) {
    std::size_t next = 0, smallest = count, largest = 0;
    for (int r = 0; r < n; ++r) {
      const auto share = parallel::share_of(count, r, n);
      EXPECT_EQ(share.begin, next);
      next = share.end;
      smallest = std::min(smallest, share.end - share.begin);
      largest = std::max(largest, share.end - share.begin);
    }
    EXPECT_EQ(next, count);
    EXPECT_LE(largest - smallest, 1u);
  }
}

TEST_F(Mpi, SharedSweepEqualsOneProcess) {
  const auto world = Communicator::world();
  if (!world.is_root()) return;
  const fs::path alone = dir_ / "sweep_alone";
  sweep(scene_path(), alone.string(), default_p2g_strategy(), {}, {}, false, Communicator::self());
  EXPECT_EQ(file_text(dir_ / "sweep" / "design.csv"), file_text(alone / "design.csv"));
  // Host backends sum P2G's per-thread grids in a fixed order: bitwise reproducible, so bitwise equal. GPUs use
  // atomics, whose order changes from run to run even on one process (docs/reliability.md: up to 24 eps of a field's
  // largest value over 280 steps; these runs take fewer): 100 eps there.
  const bool reproducible = default_p2g_strategy() == P2GStrategy::Scatter;
  const double bound = reproducible ? 0.0 : 100 * std::numeric_limits<real_t>::epsilon();
  const auto expect_close = [bound](const std::vector<double>& a, const std::vector<double>& b, const char* field) {
    ASSERT_EQ(a.size(), b.size()) << field;
    double largest = 0, difference = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      largest = std::max(largest, std::abs(b[i]));
      difference = std::max(difference, std::abs(a[i] - b[i]));
    }
    EXPECT_LE(difference, bound * largest) << field;
  };
  int runs = 0;
  for (const auto& entry : fs::directory_iterator(alone / "runs")) {
    if (entry.path().extension() != ".h5") continue;
    ++runs;
    SCOPED_TRACE(entry.path().filename().string());
    const Snapshot a = read_snapshot(entry.path().string());
    const Snapshot b = read_snapshot((dir_ / "sweep" / "runs" / entry.path().filename()).string());
    EXPECT_EQ(a.time, b.time);
    expect_close(a.x, b.x, "x");
    expect_close(a.v, b.v, "v");
    expect_close(a.F, b.F, "F");
    expect_close(a.C, b.C, "C");
  }
  EXPECT_EQ(runs, 5);
}

TEST_F(Mpi, DataParallelTrainingMatchesOneProcess) {
  const auto world = Communicator::world();
  const auto data = load_training_data({(dir_ / "sweep").string()});
  const Model shared = train_model(data, training_settings(), "", false, {}, world);
  if (!world.is_root()) return;
  const Model alone = load_model(model_path());
  ASSERT_EQ(shared.weights.size(), alone.weights.size());
  ASSERT_EQ(shared.codes.size(), alone.codes.size());
  // The ranks' gradients differ from one process's by the order of their sums only: a relative change of
  // O(samples x eps) per step (128 samples a minibatch), carried through 30 epochs x 2 minibatches of Adam, whose
  // step lr * m / sqrt(v) is insensitive to the gradient's scale. Measured: about 1e-14 (double) and 1e-6 (float)
  // of the largest parameter; the bound leaves room of a few hundred.
  const double tolerance = 1e5 * std::numeric_limits<real_t>::epsilon();
  const auto relative_difference = [](const std::vector<double>& a, const std::vector<double>& b) {
    double largest = 0, difference = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      largest = std::max(largest, std::abs(b[i]));
      difference = std::max(difference, std::abs(a[i] - b[i]));
    }
    return difference / largest;
  };
  const double weights = relative_difference(shared.weights, alone.weights);
  const double codes = relative_difference(shared.codes, alone.codes);
  std::cerr << "data-parallel training against one process: weights " << weights << ", codes " << codes
            << " of the largest value\n";
  EXPECT_LE(weights, tolerance);
  EXPECT_LE(codes, tolerance);
  EXPECT_GT(shared.weights, std::vector<double>()) << "the model trained";
}

void expect_same_rollouts(const RomResult& a, const RomResult& b) {
  EXPECT_EQ(a.times, b.times);
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.xhat, b.xhat);
  EXPECT_EQ(a.xhatdot, b.xhatdot);
  ASSERT_EQ(a.outcomes.size(), b.outcomes.size());
  for (std::size_t c = 0; c < a.outcomes.size(); ++c) {
    EXPECT_EQ(a.outcomes[c].flags, b.outcomes[c].flags) << "rollout " << c;
    EXPECT_EQ(a.outcomes[c].frames_completed, b.outcomes[c].frames_completed) << "rollout " << c;
    EXPECT_EQ(a.outcomes[c].stopped_at, b.outcomes[c].stopped_at) << "rollout " << c;
    EXPECT_EQ(a.outcomes[c].message, b.outcomes[c].message) << "rollout " << c;
    EXPECT_EQ(a.outcomes[c].warning, b.outcomes[c].warning) << "rollout " << c;
  }
}

// Slow pushes for rank 0's share, fast ones for rank 1's: alone, the shares would take different time steps. The
// last is far enough outside the training range for the energy detector to stop it early, so that the shares
// keep stepping together with stopped rollouts among them.
std::vector<RolloutCase> rollout_cases() {
  std::vector<RolloutCase> cases;
  for (const double push : {0.5, 0.6, 0.7, 1.5, 6.0}) cases.push_back({{push}, ""});
  return cases;
}

TEST_F(Mpi, SharedRolloutsEqualOneProcessForBothAlgorithms) {
  const auto world = Communicator::world();
  const Model model = load_model(model_path());
  const Scene scene = load_scene(scene_path());
  for (const RomMethod method : {RomMethod::MaterialPoint, RomMethod::SampleNode}) {
    RomSettings settings;
    settings.method = method;
    settings.samples = 8;
    settings.selection = SampleSelection::Region;  // the fixture's model ranks no samples (trained by train_model)
    settings.energy_growth = 2;
    // The pushes' outcomes (the slowest runs to the end, the fastest stops) were set with 2 x 2 x 2 Gauss points; with
    // 3 x 3 x 3 Algorithm 2's slowest push on this small model also passes the energy limit.
    settings.quadrature_order = 2;
    const auto samples = select_samples(model, scene, settings, nullptr);
    const auto reduction = build_hyper_reduction(model, scene, settings, samples);
    const auto shared = run_rollouts(world, model, scene_path(), {"push"}, rollout_cases(), settings, reduction);
    if (!world.is_root()) continue;
    const auto alone = run_rollouts(model, scene_path(), {"push"}, rollout_cases(), settings, reduction);
    SCOPED_TRACE(to_string(method));
    expect_same_rollouts(shared, alone);
    EXPECT_NE(alone.outcomes.back().flags, 0) << "the fastest rollout was meant to stop early";
    EXPECT_EQ(alone.outcomes.front().flags, 0) << "the slowest rollout was meant to run to the end";
    EXPECT_EQ(shared.cases.size(), alone.cases.size());
  }
}

TEST_F(Mpi, RolloutResumesFromCheckpointsOfDifferentFrames) {
  const auto world = Communicator::world();
  const Model model = load_model(model_path());
  const Scene scene = load_scene(scene_path());
  RomSettings settings;
  settings.samples = 8;
  settings.selection = SampleSelection::Region;  // the fixture's model ranks no samples (trained by train_model)
  const auto reduction = build_hyper_reduction(model, scene, settings, select_samples(model, scene, settings, nullptr));
  RolloutCheckpoint checkpoint;
  checkpoint.path = (dir_ / "rom.h5.ckpt").string();
  checkpoint.seconds = 0;  // at every output frame but the last: frames 1, 2 and 3 of 0-4
  const auto file_of = [&](int rank) { return rank_checkpoint_path(checkpoint.path, rank, world.size()); };
  // Rank 0 reports frame 2 after every rank wrote frame 1's checkpoint and before any writes frame 2's: it keeps
  // a copy of each rank's frame-1 checkpoint then.
  const auto keep_frame_1 = [&](const RomProgress& p) {
    if (p.frame != 2) return;
    for (int r = 0; r < world.size(); ++r)
      fs::copy_file(file_of(r), file_of(r) + ".frame1", fs::copy_options::overwrite_existing);
  };
  const auto reference = run_rollouts(world, model, scene_path(), {"push"}, rollout_cases(), settings, reduction,
                                      keep_frame_1, checkpoint);
  world.barrier();
  if (world.is_root()) {
    // Killed while the ranks wrote frame 3's checkpoints: rank 0 had renamed frame 1's (here standing for frame
    // 2's) to .prev and written frame 3's; the others had not started.
    fs::rename(file_of(0) + ".frame1", file_of(0) + ".prev");
    for (int r = 1; r < world.size(); ++r) fs::rename(file_of(r) + ".frame1", file_of(r));
  }
  world.barrier();
  checkpoint.resume = true;
  const auto from_frame_1 =
      run_rollouts(world, model, scene_path(), {"push"}, rollout_cases(), settings, reduction, {}, checkpoint);
  if (world.is_root()) {
    SCOPED_TRACE("resumed from frame 1");
    expect_same_rollouts(from_frame_1, reference);
    EXPECT_FALSE(fs::exists(file_of(0) + ".prev")) << "the last complete checkpoints are removed once replaced";
    // Killed right after the last rank renamed its checkpoint to .prev, before writing the new one.
    fs::rename(file_of(world.size() - 1), file_of(world.size() - 1) + ".prev");
  }
  world.barrier();
  const auto from_frame_3 =
      run_rollouts(world, model, scene_path(), {"push"}, rollout_cases(), settings, reduction, {}, checkpoint);
  if (world.is_root()) {
    SCOPED_TRACE("resumed from frame 3, one rank's checkpoint in .prev");
    expect_same_rollouts(from_frame_3, reference);
  }
}

}  // namespace
}  // namespace mpmrom::test

// MPI around GoogleTest and Kokkos: every rank runs every test; collectives inside keep them in step.
int main(int argc, char** argv) {
  mpmrom::parallel::Session mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  Kokkos::ScopeGuard kokkos(argc, argv);
  return RUN_ALL_TESTS();
}
