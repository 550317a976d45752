// Killed runs (SIGKILL, no chance to clean up) resume with --resume and finish with results bitwise identical to an
// uninterrupted run, through the command line as users run it; and the same inputs give the same outputs.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "mpmrom/model.hpp"
#include "fixtures.hpp"
#include "mpmrom/rom.hpp"
#include "rom/rom_file.hpp"
#include "mpmrom/snapshot.hpp"

extern char** environ;

namespace mpmrom::test {
namespace {

namespace fs = std::filesystem;

// Five runs of the pushed block: about 0.2 s each on one core, so a kill lands mid-sweep.
const std::string kScene = pushed_block_scene("resume_block", 0.5, 10, 0.2, {0.5, 0.75, 1.0, 1.25, 1.5}, 2);

class Resume : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mpmrom_test_resume_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    scene_ = (dir_ / "scene.toml").string();
    std::ofstream(scene_) << kScene;
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The build's CLI, or MPMROM_CLI from the environment where the tests run on another machine than they were built.
  static std::string cli() {
    const char* from_environment = std::getenv("MPMROM_CLI");
    return from_environment != nullptr ? from_environment : MPMROM_CLI;
  }
  static pid_t start(const std::vector<std::string>& args) {
    const std::string program = cli();
    std::vector<std::string> argv_strings{program, "-q"};
    argv_strings.insert(argv_strings.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_strings) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = 0;
    if (posix_spawn(&pid, program.c_str(), nullptr, nullptr, argv.data(), environ) != 0) return -1;
    return pid;
  }
  static int wait_for(pid_t pid) {
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  static int run(const std::vector<std::string>& args) { return wait_for(start(args)); }
  // Starts the command, SIGKILLs it as soon as `marker` exists, and says whether it was killed before it finished.
  static bool run_and_kill_at(const std::vector<std::string>& args, const fs::path& marker) {
    const pid_t pid = start(args);
    int status = 0;
    while (!fs::exists(marker)) {
      if (::waitpid(pid, &status, WNOHANG) == pid) return false;  // finished before the marker appeared
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    return WIFSIGNALED(status);
  }

  fs::path dir_;
  std::string scene_;
};

// Host backends sum P2G in a fixed order, so equal inputs give bitwise-equal runs. GPUs sum it with atomics in
// arrival order (docs/reliability.md): runs then differ by round-off, which grows over the ~93 steps of these runs
// to well below 1e3 eps of the field's largest value (each step adds a few eps; the elastic block does not amplify).
const bool kBitwiseRuns =
    Kokkos::SpaceAccessibility<Kokkos::HostSpace, Kokkos::DefaultExecutionSpace::memory_space>::accessible;

void expect_same_field(const std::vector<double>& x, const std::vector<double>& y, const std::string& what) {
  if (kBitwiseRuns) {
    EXPECT_EQ(x, y) << what;
    return;
  }
  ASSERT_EQ(x.size(), y.size()) << what;
  double scale = 0, worst = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    scale = std::max(scale, std::fabs(x[i]));
    worst = std::max(worst, std::fabs(x[i] - y[i]));
  }
  EXPECT_LE(worst, 1e3 * std::numeric_limits<real_t>::epsilon() * scale) << what;
}

void expect_same_run(const std::string& a, const std::string& b) {
  const Snapshot x = read_snapshot(a), y = read_snapshot(b);
  EXPECT_EQ(x.time, y.time) << a;
  expect_same_field(x.x, y.x, a + ": x");
  expect_same_field(x.v, y.v, a + ": v");
  expect_same_field(x.F, y.F, a + ": F");
  expect_same_field(x.C, y.C, a + ": C");
}

std::vector<fs::path> run_files(const fs::path& sweep) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(sweep / "runs")) files.push_back(entry.path().filename());
  std::sort(files.begin(), files.end());
  return files;
}

TEST_F(Resume, SameInputsGiveBitwiseIdenticalRuns) {
  ASSERT_EQ(run({"simulate", scene_, "--out", (dir_ / "a.h5").string()}), 0);
  ASSERT_EQ(run({"simulate", scene_, "--out", (dir_ / "b.h5").string()}), 0);
  expect_same_run((dir_ / "a.h5").string(), (dir_ / "b.h5").string());
}

TEST_F(Resume, KilledSweepResumesToTheUninterruptedResult) {
  const fs::path whole = dir_ / "whole", killed = dir_ / "killed";
  ASSERT_EQ(run({"sweep", scene_, "--out", whole.string()}), 0);
  // Killed once its second run is on disk: the third was in progress, its temporary file left behind.
  ASSERT_TRUE(run_and_kill_at({"sweep", scene_, "--out", killed.string()}, killed / "runs" / "run_001.h5"));
  EXPECT_FALSE(fs::exists(killed / "design.csv"));
  EXPECT_FALSE(fs::exists(killed / "runs" / "run_004.h5"));
  ASSERT_EQ(run({"sweep", scene_, "--out", killed.string(), "--resume"}), 0);
  EXPECT_EQ(run_files(killed), run_files(whole));  // no temporary left, nothing missing
  for (const auto& file : run_files(whole))
    if (file.extension() == ".h5") expect_same_run((whole / "runs" / file).string(), (killed / "runs" / file).string());
  std::ifstream a(whole / "design.csv"), b(killed / "design.csv");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(a), {}), std::string(std::istreambuf_iterator<char>(b), {}));
}

TEST_F(Resume, ResumingASweepOfAnotherSceneIsRefused) {
  const fs::path sweep = dir_ / "sweep";
  ASSERT_EQ(run({"sweep", scene_, "--out", sweep.string()}), 0);
  std::string other = kScene;
  other.replace(other.find("cfl = 0.2"), 9, "cfl = 0.3");
  std::ofstream(dir_ / "other.toml") << other;
  EXPECT_NE(run({"sweep", (dir_ / "other.toml").string(), "--out", sweep.string(), "--resume"}), 0);
  EXPECT_EQ(run({"sweep", (dir_ / "other.toml").string(), "--out", sweep.string()}), 0);  // without: replaced
}

TEST_F(Resume, KilledTrainingResumesToTheUninterruptedModel) {
  const fs::path sweep = dir_ / "sweep";
  ASSERT_EQ(run({"sweep", scene_, "--out", sweep.string()}), 0);
  const std::vector<std::string> train{
      "train", sweep.string(),         "--latent", "2", "--width", "8", "--depth", "3", "--epochs",
      "60",    "--checkpoint-seconds", "0"};
  auto with = [&](std::vector<std::string> args, const std::vector<std::string>& more) {
    args.insert(args.end(), more.begin(), more.end());
    return args;
  };
  const std::string whole = (dir_ / "whole.h5").string(), killed = (dir_ / "killed.h5").string();
  ASSERT_EQ(run(with(train, {"--out", whole})), 0);
  // Killed once a checkpoint exists (one is written after every epoch here).
  ASSERT_TRUE(run_and_kill_at(with(train, {"--out", killed}), killed + ".ckpt"));
  EXPECT_FALSE(fs::exists(killed));
  ASSERT_EQ(run(with(train, {"--out", killed, "--resume"})), 0);
  EXPECT_FALSE(fs::exists(killed + ".ckpt"));
  const Model a = load_model(whole), b = load_model(killed);
  EXPECT_EQ(a.weights, b.weights);
  EXPECT_EQ(a.codes, b.codes);
}

// A long batch of rollouts (16 rollouts over twice the scene's horizon, a checkpoint at every output frame) killed
// mid-way resumes from its checkpoint to the uninterrupted result, bit for bit: the reduced model gathers node
// velocities in a fixed order on every backend, and the checkpoint keeps every state (Algorithm 2's warm starts too)
// at full precision.
TEST_F(Resume, KilledRolloutResumesToTheUninterruptedResult) {
  const fs::path sweep = dir_ / "sweep";
  ASSERT_EQ(run({"sweep", scene_, "--out", sweep.string()}), 0);
  const std::string model = (dir_ / "model.h5").string();
  // --scene: the model stores the default sample set, which the rollouts below take (no fit at their set-up).
  ASSERT_EQ(run({"train", sweep.string(), "--out", model, "--latent", "2", "--width", "8", "--depth", "3", "--epochs",
                 "30", "--scene", scene_}),
            0);
  ASSERT_EQ(load_model(model).projection_samples.size(), std::size_t(RomSettings{}.samples));
  {
    std::ofstream params(dir_ / "params.csv");
    params << "push\n";
    for (int b = 0; b < 16; ++b) params << 0.5 + 0.0625 * b << "\n";
  }
  for (const std::string method : {"point", "node", "galerkin"}) {  // each with its default flags
    const std::vector<std::string> rollout{"rollout",
                                           model,
                                           scene_,
                                           "--params",
                                           (dir_ / "params.csv").string(),
                                           "--method",
                                           method,
                                           "--end-time",
                                           "1",
                                           "--checkpoint-seconds",
                                           "0",
                                           "--energy-growth",
                                           "0"};
    auto with = [&](std::vector<std::string> args, const std::vector<std::string>& more) {
      args.insert(args.end(), more.begin(), more.end());
      return args;
    };
    const std::string whole = (dir_ / ("whole_" + method + ".h5")).string();
    const std::string killed = (dir_ / ("killed_" + method + ".h5")).string();
    const int status = run(with(rollout, {"--out", whole}));
    ASSERT_TRUE(status == 0 || status == 3) << status;  // 3: some rollouts stopped by a detector, the same each time
    ASSERT_TRUE(run_and_kill_at(with(rollout, {"--out", killed}), killed + ".ckpt")) << method;
    EXPECT_FALSE(fs::exists(killed));
    ASSERT_EQ(run(with(rollout, {"--out", killed, "--resume"})), status) << method;
    EXPECT_FALSE(fs::exists(killed + ".ckpt"));
    const RomFile a = load_rom(whole), b = load_rom(killed);
    EXPECT_EQ(a.result.steps, b.result.steps) << method;
    EXPECT_EQ(a.result.xhat, b.result.xhat) << method;
    EXPECT_EQ(a.result.xhatdot, b.result.xhatdot) << method;
    for (std::size_t r = 0; r < a.result.outcomes.size(); ++r) {
      EXPECT_EQ(a.result.outcomes[r].flags, b.result.outcomes[r].flags) << method << " rollout " << r;
      EXPECT_EQ(a.result.outcomes[r].frames_completed, b.result.outcomes[r].frames_completed) << r;
      EXPECT_EQ(a.result.outcomes[r].message, b.result.outcomes[r].message) << r;
      EXPECT_EQ(a.result.outcomes[r].inversion_failures, b.result.outcomes[r].inversion_failures) << r;
    }
  }
}

TEST_F(Resume, ResumingARolloutFromAnotherBatchIsRefused) {
  const fs::path sweep = dir_ / "sweep";
  ASSERT_EQ(run({"sweep", scene_, "--out", sweep.string()}), 0);
  const std::string model = (dir_ / "model.h5").string(), rom = (dir_ / "rom.h5").string();
  ASSERT_EQ(
      run({"train", sweep.string(), "--out", model, "--latent", "2", "--width", "8", "--depth", "3", "--epochs", "10"}),
      0);
  const std::vector<std::string> rollout{
      "rollout", model, scene_, "--out", rom, "--samples", "8", "--checkpoint-seconds", "0", "--end-time", "5"};
  ASSERT_TRUE(run_and_kill_at(rollout, rom + ".ckpt"));
  std::vector<std::string> other = rollout;
  other.insert(other.end(), {"--cfl", "0.1", "--resume"});  // another time step: another batch
  EXPECT_EQ(run(other), 1);
  EXPECT_TRUE(fs::exists(rom + ".ckpt"));  // kept for the run it belongs to
  std::vector<std::string> same = rollout;
  same.push_back("--resume");
  EXPECT_LE(run(same), 3);
  EXPECT_TRUE(fs::exists(rom));
}

// A rollout that reuses an earlier one's hyper-reduction (--reduction) repeats it bit for bit without fitting it
// again, over another horizon too; settings the fits depend on, or another model, are refused with nothing written.
TEST_F(Resume, RolloutReusingAnEarlierReductionRepeatsIt) {
  const fs::path sweep = dir_ / "sweep";
  ASSERT_EQ(run({"sweep", scene_, "--out", sweep.string()}), 0);
  const std::string model = (dir_ / "model.h5").string(), other_model = (dir_ / "other.h5").string();
  for (const auto& [path, epochs] : {std::pair{model, "10"}, std::pair{other_model, "11"}})
    ASSERT_EQ(run({"train", sweep.string(), "--out", path, "--latent", "2", "--width", "8", "--depth", "3", "--epochs",
                   epochs}),
              0);
  const std::string fitted = (dir_ / "fitted.h5").string(), reused = (dir_ / "reused.h5").string();
  const std::vector<std::string> galerkin{"--method", "galerkin", "--samples", "6", "--energy-growth", "0"};
  auto rollout = [&](const std::string& with_model, const std::string& out, std::vector<std::string> more) {
    std::vector<std::string> args{"rollout", with_model, scene_, "--out", out};
    args.insert(args.end(), galerkin.begin(), galerkin.end());
    args.insert(args.end(), more.begin(), more.end());
    return run(args);
  };
  ASSERT_EQ(rollout(model, fitted, {}), 0);
  ASSERT_EQ(rollout(model, reused, {"--reduction", fitted}), 0);
  const RomFile a = load_rom(fitted), b = load_rom(reused);
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(a.sets.weights, b.sets.weights);
  EXPECT_EQ(a.sets.stable_time_step, b.sets.stable_time_step);
  EXPECT_EQ(a.result.xhat, b.result.xhat);  // the same step from the same sets
  EXPECT_EQ(b.hyper_reduction.value("reused_from", std::string()), fs::absolute(fitted).string());
  ASSERT_EQ(rollout(model, reused, {"--reduction", fitted, "--end-time", "0.2"}), 0);
  // The first frames of the same rollouts, to round-off: the shorter horizon's output times (end_time frame /
  // outputs) can differ from the longer one's by an ulp, and so the steps; 1e3 eps covers that over its 40 steps.
  const RomFile shorter = load_rom(reused);
  const std::size_t frames = shorter.result.times.size(), r = std::size_t(a.result.latent_dim);
  ASSERT_LT(frames, a.result.times.size());
  const std::size_t B = a.result.outcomes.size(), F = a.result.times.size();
  double scale = 0, worst = 0;
  for (std::size_t b = 0; b < B; ++b)
    for (std::size_t i = 0; i < frames * r; ++i) {
      const double x = a.result.xhat[b * F * r + i], y = shorter.result.xhat[b * frames * r + i];
      scale = std::max(scale, std::fabs(x));
      worst = std::max(worst, std::fabs(x - y));
    }
  EXPECT_LE(worst, 1e3 * std::numeric_limits<real_t>::epsilon() * scale);
  const std::string refused = (dir_ / "refused.h5").string();
  EXPECT_EQ(rollout(model, refused, {"--reduction", fitted, "--galerkin-strain", "continuum"}), 1);
  EXPECT_EQ(rollout(other_model, refused, {"--reduction", fitted}), 1);
  EXPECT_EQ(rollout(model, refused, {"--reduction", fitted, "--galerkin-node-average"}), 1);
  EXPECT_FALSE(fs::exists(refused));
  // A file written before a setting existed (here: its key removed) serves that setting at its default only.
  RomFile older = load_rom(fitted);
  older.settings.erase("galerkin_node_average");
  const Model loaded = load_model(model);
  const Scene scene = load_scene(scene_);
  RomSettings settings = rom_defaults(RomMethod::Galerkin);  // as the command line's flags above
  settings.samples = 6;
  settings.energy_growth = 0;
  EXPECT_NO_THROW(reduction_from_rom(older, fitted, loaded, scene, settings));
  // The fits probe each state's own terms whatever the integrator: either one reuses them.
  settings.integrator = TimeIntegrator::SymplecticEuler;
  EXPECT_NO_THROW(reduction_from_rom(older, fitted, loaded, scene, settings));
  settings.galerkin_node_average = true;
  EXPECT_THROW(reduction_from_rom(older, fitted, loaded, scene, settings), std::runtime_error);
}

}  // namespace
}  // namespace mpmrom::test
