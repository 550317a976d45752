// ROM.h5 (docs/rom_format.md): a batch of reduced rollouts: the parameters of each, the latent trajectories, what
// happened to each rollout, the settings and hyper-reduction, and optionally the decoded fields at a set of points.
// Decoding needs the model, which the file names (path and checksum) rather than copies.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "mpmrom/model.hpp"
#include "mpmrom/rom.hpp"

namespace mpmrom {

inline constexpr const char* rom_format = "mpmrom-rom";
inline constexpr int rom_format_version = 3;  // 3: fixed-length string attributes (1, 2: variable-length)

struct RomFile {
  RomResult result;
  std::string model_path;
  std::uint64_t model_checksum = 0;
  std::string scene_name, scene_text;
  nlohmann::json settings = nlohmann::json::object();
  nlohmann::json hyper_reduction = nlohmann::json::object();
  nlohmann::json timing = nlohmann::json::object();
  std::vector<int> samples;
  // The precomputed sets the rollouts ran with (source points, node set I and its gather lists, quadrature points),
  // in /hyper_reduction: enough for a peer outside mpmrom to re-run the same step (perf/peers/). Empty in files
  // written before the group existed.
  HyperReduction sets;
  // Decoded fields (optional): points X (n, 3); x, v (rollouts, frames, n, 3); F (rollouts, frames, n, 3, 3).
  std::vector<double> decoded_X, decoded_x, decoded_v, decoded_F;
};

// FNV-1a over the model's weights: a ROM file is evaluated with the network it was run with, or not at all.
std::uint64_t model_checksum(const Model& model);

// Writes atomically. Throws std::runtime_error on an inconsistent file or a non-finite value.
void save_rom(const std::string& path, const RomFile& rom);
// Reads and checks everything (format, version, completeness, shapes, finite values); one-line errors.
RomFile load_rom(const std::string& path);

// The hyper-reduction rom (read from path) ran with, for rollouts of the same model, scene and settings: what the
// offline fits cost (minutes to hours on a large body) is paid once. Settings may differ in the horizon and the
// energy detector only, and in the CFL number where the fits do not see it (the Galerkin step fits at the scene's step
// when the rollout's is longer). Throws std::runtime_error naming what differs.
HyperReduction reduction_from_rom(const RomFile& rom, const std::string& path, const Model& model, const Scene& scene,
                                  const RomSettings& settings);

}  // namespace mpmrom
