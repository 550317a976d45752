#include "mpmrom/training_data.hpp"

#include <algorithm>
#include <numeric>
#include <random>
#include <utility>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace mpmrom {
namespace {

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string field;
  while (std::getline(in, field, ',')) {
    while (!field.empty() && (field.back() == '\r' || field.back() == ' ')) field.pop_back();
    fields.push_back(field);
  }
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

void require_same_reference(const std::vector<double>& first_X, const std::string& first_file,
                            const std::vector<double>& X, const std::string& file) {
  if (X.size() != first_X.size())
    throw std::runtime_error(file + ": has " + std::to_string(X.size() / 3) + " material points, " + first_file +
                             " has " + std::to_string(first_X.size() / 3) + " (a model is trained on one point set)");
  double extent = 0, largest = 0;
  for (std::size_t i = 0; i < X.size(); ++i) {
    extent = std::max(extent, std::abs(first_X[i]));
    largest = std::max(largest, std::abs(X[i] - first_X[i]));
  }
  // Runs of one scene write identical reference points; 1e-6 of the extent allows a float/double mix.
  if (largest > 1e-6 * std::max(extent, 1e-300))
    throw std::runtime_error(file + ": its reference points differ from those of " + first_file + " by up to " +
                             std::to_string(largest) + " m (a model is trained on one point set)");
}

}  // namespace

std::vector<std::string> design_column(const std::string& csv_path, const std::string& column) {
  std::ifstream in(csv_path);
  if (!in) throw std::runtime_error(csv_path + ": cannot open the design file");
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(csv_path + ": empty design file");
  const auto header = split_csv_line(line);
  const auto where = std::find(header.begin(), header.end(), column);
  if (where == header.end()) throw std::runtime_error(csv_path + ": no column '" + column + "'");
  const std::size_t index = std::size_t(where - header.begin());
  std::vector<std::string> values;
  int row = 1;
  while (std::getline(in, line)) {
    ++row;
    if (line.empty() || line == "\r") continue;
    const auto fields = split_csv_line(line);
    if (fields.size() != header.size())
      throw std::runtime_error(csv_path + ": row " + std::to_string(row) + " has " + std::to_string(fields.size()) +
                               " fields, the header has " + std::to_string(header.size()));
    values.push_back(fields[index]);
  }
  return values;
}

namespace {

// The inputs' runs as (path, test): each sweep directory's design.csv rows, each other input a training run.
std::vector<std::pair<std::string, bool>> list_runs(const std::vector<std::string>& inputs) {
  if (inputs.empty()) throw std::runtime_error("no full-order runs given");
  std::vector<std::pair<std::string, bool>> files;  // (path, test)
  for (const auto& input : inputs) {
    std::error_code error;
    if (std::filesystem::is_directory(input, error)) {
      const auto csv = (std::filesystem::path(input) / "design.csv").string();
      const auto split = design_column(csv, "split");
      const auto file = design_column(csv, "file");
      for (std::size_t i = 0; i < split.size(); ++i) {
        if (split[i] != "train" && split[i] != "test")
          throw std::runtime_error(csv + ": split of row " + std::to_string(i + 2) + " is '" + split[i] +
                                   "', expected train or test");
        files.emplace_back((std::filesystem::path(input) / file[i]).string(), split[i] == "test");
      }
    } else {
      files.emplace_back(input, false);
    }
  }
  return files;
}

// The runs listed, the training runs at train_points (empty: every point), each checked against the first's reference.
TrainingData read_runs(const std::vector<std::pair<std::string, bool>>& files,
                       const std::function<void(const std::string&)>& on_file, SnapshotFields fields,
                       const std::vector<std::size_t>& train_points) {
  TrainingData data;
  std::vector<double> first_X;
  std::string first_file;
  for (const auto& [file, test] : files) {
    if (on_file) on_file(file);
    RunSet& set = test ? data.test : data.train;
    set.runs.push_back(read_snapshot(file, fields, test ? std::vector<std::size_t>() : train_points));
    set.files.push_back(file);
    const Snapshot& run = set.runs.back();
    if (test && !train_points.empty() && run.num_points <= train_points.back())
      throw std::runtime_error(file + ": has " + std::to_string(run.num_points) +
                               " material points, fewer than the training runs (a model is trained on one point set)");
    std::vector<double> X;  // the reference at the training runs' points
    if (test && !train_points.empty()) {
      for (const std::size_t p : train_points) X.insert(X.end(), run.X.begin() + 3 * p, run.X.begin() + 3 * p + 3);
    } else {
      X = run.X;
    }
    if (first_file.empty()) {
      first_X = X;
      first_file = file;
    } else {
      require_same_reference(first_X, first_file, X, file);
    }
  }
  return data;
}

}  // namespace

TrainingData load_runs(const std::vector<std::string>& inputs, const std::function<void(const std::string&)>& on_file,
                       SnapshotFields fields) {
  return read_runs(list_runs(inputs), on_file, fields, {});
}

TrainingData load_training_data(const std::vector<std::string>& inputs,
                                const std::function<void(const std::string&)>& on_file, SnapshotFields fields,
                                std::size_t max_points, std::uint64_t seed) {
  const auto files = list_runs(inputs);
  const auto first_train = std::find_if(files.begin(), files.end(), [](const auto& f) { return !f.second; });
  if (first_train == files.end()) throw std::runtime_error("no training runs among the inputs (all are test runs)");
  std::vector<std::size_t> train_points;
  SnapshotReference reference;
  if (max_points > 0) {
    reference = read_snapshot_reference(first_train->first);
    const std::size_t n = reference.mass.size();
    if (max_points < n) {
      train_points.resize(n);
      std::iota(train_points.begin(), train_points.end(), std::size_t(0));
      std::mt19937_64 generator(seed);
      for (std::size_t i = 0; i < max_points; ++i)  // the first max_points of a partial Fisher-Yates shuffle
        std::swap(train_points[i], train_points[i + generator() % (n - i)]);
      train_points.resize(max_points);
      std::sort(train_points.begin(), train_points.end());
    } else {
      reference = {};
    }
  }
  TrainingData data = read_runs(files, on_file, fields, train_points);
  data.reference = std::move(reference);
  return data;
}

}  // namespace mpmrom
