#include "rom/detail/training_frames.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>

namespace mpmrom::impl {

std::vector<TrainingFrame> training_frames(const Model& model, const TrainingData& data, std::size_t count) {
  const auto file_name = [](const std::string& path) { return std::filesystem::path(path).filename().string(); };
  std::map<std::string, std::size_t> run_index;
  for (std::size_t i = 0; i < data.train.files.size(); ++i) run_index[file_name(data.train.files[i])] = i;
  std::vector<TrainingFrame> frames;
  for (std::size_t c = 0; c < model.num_codes(); ++c) {
    const auto it = run_index.find(file_name(model.runs.at(std::size_t(model.code_run[c]))));
    if (it == run_index.end()) continue;
    const Snapshot& run = data.train.runs[it->second];
    for (std::size_t f = 0; f < run.num_frames; ++f)
      if (std::fabs(run.time[f] - model.code_time[c]) <= 1e-9 * std::max(1.0, run.time.back()))
        frames.push_back({c, it->second, f});
  }
  if (frames.empty()) throw std::runtime_error("none of the model's training runs is among the given --data runs");
  std::vector<TrainingFrame> picked;
  const std::size_t stride = std::max<std::size_t>(1, frames.size() / std::max<std::size_t>(1, count));
  for (std::size_t i = stride / 2; i < frames.size(); i += stride) picked.push_back(frames[i]);
  return picked;
}

std::vector<double> frame_accelerations(const Snapshot& run, std::size_t frame) {
  const std::size_t P = run.num_points, before = frame > 0 ? frame - 1 : frame;
  const std::size_t after = frame + 1 < run.num_frames ? frame + 1 : frame;
  std::vector<double> a(P * 3, 0.0);
  if (after == before) return a;
  const double span = run.time[after] - run.time[before];
  for (std::size_t i = 0; i < P * 3; ++i) a[i] = (run.v[after * P * 3 + i] - run.v[before * P * 3 + i]) / span;
  return a;
}

}  // namespace mpmrom::impl
