// Full-order runs gathered for training and testing a reduced model.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "mpmrom/snapshot.hpp"

namespace mpmrom {

struct RunSet {
  std::vector<std::string> files;  // as given or as listed in design.csv (joined to its directory)
  std::vector<Snapshot> runs;
};

struct TrainingData {
  RunSet train, test;
  // Where the training runs hold some of the points (load_training_data's max_points; their Snapshot::point_ids):
  // every point's reference configuration, which the model keeps. Empty otherwise.
  SnapshotReference reference;
};

// Each input is a sweep directory (its design.csv's `split` column puts each run in train or test) or one snapshot
// file (train). Every run must share the same reference points; throws std::runtime_error with one line otherwise
// or on any unreadable input. on_file is told each file before it is read. Any split will do (e.g. reference runs
// for evaluation, which may all be test runs). fields: whether APIC's C is read too.
TrainingData load_runs(const std::vector<std::string>& inputs,
                       const std::function<void(const std::string&)>& on_file = {},
                       SnapshotFields fields = SnapshotFields::WithoutAffine);

// load_runs for training: at least one run must be a training run. max_points > 0 and below the runs' point count:
// the training runs hold that many points, drawn at random (seed) and the same in every run, read a frame at a time;
// data.reference holds every point's reference; the test runs are read whole.
TrainingData load_training_data(const std::vector<std::string>& inputs,
                                const std::function<void(const std::string&)>& on_file = {},
                                SnapshotFields fields = SnapshotFields::WithoutAffine, std::size_t max_points = 0,
                                std::uint64_t seed = 0);

// The rows of a design.csv: the value of `column` in each row (throws if the file or the column is missing).
std::vector<std::string> design_column(const std::string& csv_path, const std::string& column);

}  // namespace mpmrom
