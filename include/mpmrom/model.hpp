// A trained deformation map g(X; xhat) (src/manifold/nn/mlp.hpp) with everything needed to use and to audit it:
// weights, standardisation, the training snapshots' latent codes, the reference configuration, the settings it was
// trained with and its errors. Stored as HDF5 (docs/model_format.md); a training checkpoint is a model file with the
// optimiser's state added.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "mpmrom/network.hpp"

namespace mpmrom {

inline constexpr const char* model_format = "mpmrom-model";
inline constexpr int model_format_version = 2;  // 2: fixed-length string attributes (1: variable-length)

struct Model {
  int latent_dim = 0;
  int width = 0;
  int depth = 0;  // affine layers (depth - 1 hidden ELU layers and a linear output layer)
  nn::Standardization<double> standardization;
  std::vector<double> weights;  // MlpLayout::make(latent_dim, width, depth).num_params values

  // One code per training snapshot: codes (snapshots, r); code_run names the snapshot's run (an index into runs)
  // and code_time its time.
  std::vector<double> codes;
  std::vector<std::int64_t> code_run;
  std::vector<double> code_time;
  std::vector<std::string> runs;

  // The reference configuration the map was trained on: X (points, 3), mass, volume (points).
  std::vector<double> X, mass, volume;

  // Sample points in greedy order (rank_samples_greedily, from the training runs): the first k are the greedy
  // selection of k samples, so a rollout needs no training data to select them. Empty in models without one.
  std::vector<std::int64_t> sample_ranking;
  // The default hyper-reduction's samples and their fitted weights (the rom stage's greedy projection selection,
  // docs/rom.md), stored by `mpmrom train --scene` and the pipeline. Empty in models without one.
  std::vector<std::int64_t> projection_samples;
  std::vector<double> projection_weights;
  // The RomSettings::selection_sensitivities the stored set was chosen among (absent in a file: {0}).
  std::vector<double> projection_sensitivities = {0};

  std::string scene_name;
  std::string scene_text;
  nlohmann::json settings = nlohmann::json::object();  // training settings, as given
  nlohmann::json errors = nlohmann::json::object();    // final train / validation / test errors
  double loss_scales[4] = {1, 1, 1, 1};                // position, F, velocity, C F: the RMS values the loss divides by
  std::string precision;                               // of the build that wrote it (set on save)

  nn::MlpLayout layout() const { return nn::MlpLayout::make(latent_dim, width, depth); }
  std::size_t num_codes() const { return latent_dim > 0 ? codes.size() / latent_dim : 0; }
  std::size_t num_points() const { return mass.size(); }
};

// The optimiser's state in a checkpoint: Adam moments over weights then codes, steps taken, epochs finished.
struct OptimizerState {
  std::vector<double> first_moment, second_moment;
  std::int64_t step = 0;
  std::int64_t epoch = 0;
};

// Writes atomically (temporary name, then rename). Throws std::runtime_error on an inconsistent model.
void save_model(const std::string& path, const Model& model, const OptimizerState* optimizer = nullptr);

// Reads and checks a model file: format and version, completeness, shapes consistent with the architecture, finite
// values. Throws std::runtime_error with one line naming the file and the problem. optimizer, if given, receives the
// checkpoint state (an error if the file has none).
Model load_model(const std::string& path, OptimizerState* optimizer = nullptr);

}  // namespace mpmrom
