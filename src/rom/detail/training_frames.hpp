// The training snapshots the reduced model's offline fits use (the greedy sample selection, the cubature weights):
// model codes matched with the frames of the full-order training runs they encode.
#pragma once

#include <cstddef>
#include <vector>

#include "mpmrom/model.hpp"
#include "mpmrom/training_data.hpp"

namespace mpmrom::impl {

// A model code and the frame of its run in the training data (data.train.runs[run], frame `frame`).
struct TrainingFrame {
  std::size_t code, run, frame;
};

// About `count` codes whose run is among data's training runs, spread evenly over all of them. Runs are matched by
// file name: the model records the paths it was trained from, which may have moved since. Throws when no run matches.
std::vector<TrainingFrame> training_frames(const Model& model, const TrainingData& data, std::size_t count);

// The full-order accelerations of every point at a frame of a run, (P, 3): central differences of the frames'
// velocities (one-sided at the run's ends).
std::vector<double> frame_accelerations(const Snapshot& run, std::size_t frame);

}  // namespace mpmrom::impl
