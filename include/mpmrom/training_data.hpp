// Full-order runs gathered for training and testing a reduced model.
#pragma once

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
};

// Each input is a sweep directory (its design.csv's `split` column puts each run in train or test) or one snapshot
// file (train). Every run must share the same reference points; throws std::runtime_error with one line otherwise
// or on any unreadable input. on_file is told each file before it is read. Any split will do (e.g. reference runs
// for evaluation, which may all be test runs). fields: whether APIC's C is read too.
TrainingData load_runs(const std::vector<std::string>& inputs,
                       const std::function<void(const std::string&)>& on_file = {},
                       SnapshotFields fields = SnapshotFields::WithoutAffine);

// load_runs for training: at least one run must be a training run.
TrainingData load_training_data(const std::vector<std::string>& inputs,
                                const std::function<void(const std::string&)>& on_file = {},
                                SnapshotFields fields = SnapshotFields::WithoutAffine);

// The rows of a design.csv: the value of `column` in each row (throws if the file or the column is missing).
std::vector<std::string> design_column(const std::string& csv_path, const std::string& column);

}  // namespace mpmrom
