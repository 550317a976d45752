// The deployment API's tests' shared fixture (analysis/test_api.cpp, test_offline_fits.cpp): a small pushed-block
// design swept and a small network trained on it once per test executable, with the stored sample sets `mpmrom train`
// adds.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "mpmrom/model.hpp"
#include "fixtures.hpp"
#include "mpmrom/rollout_batch.hpp"
#include "snapshots/simulate.hpp"
#include "manifold/trainer.hpp"
#include "mpmrom/training_data.hpp"

namespace mpmrom::test {
namespace {

namespace fs = std::filesystem;

// The scene file's design swept into dir/sweep and a small network (r = 2, 3 layers of 8, 30 epochs) trained on it,
// written to model_path with the weights as stored; the sweep's training data, returned.
inline TrainingData sweep_and_train_small_model(const std::string& scene_path, const fs::path& dir,
                                                const std::string& model_path) {
  sweep(scene_path, (dir / "sweep").string(), default_p2g_strategy());
  TrainingSettings settings;
  settings.latent_dim = 2;
  settings.width = 8;
  settings.depth = 3;
  settings.epochs = 30;
  auto data = load_training_data({(dir / "sweep").string()});
  save_model(model_path, train_model(data, settings, "", false));
  return data;
}

// Three pushes; 4 output frames over 0.04 s.
const std::string kScene = pushed_block_scene("pushed_block", 0.04, 4, 0.4, {0.5, 1.0, 1.5}, 1);

class RolloutBatchApi : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mpmrom-test-api-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(scene_path()) << kScene;
    const auto data = sweep_and_train_small_model(scene_path(), dir_, unranked_model_path());
    Model model = load_model(unranked_model_path());  // the weights as stored, in the build's precision
    model.sample_ranking = rank_samples_greedily(model, data, ranked_samples);  // as `mpmrom train` stores it
    const Scene scene = load_scene(scene_path());
    store_projection_samples(model, scene, default_projection_selector(model, scene),
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

}  // namespace
}  // namespace mpmrom::test
