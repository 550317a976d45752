#include "mpmrom/training_data.hpp"

#include <algorithm>
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

void require_same_reference(const std::vector<double>& first_X, const std::string& first_file, const Snapshot& run,
                            const std::string& file) {
  if (run.X.size() != first_X.size())
    throw std::runtime_error(file + ": has " + std::to_string(run.num_points) + " material points, " + first_file +
                             " has " + std::to_string(first_X.size() / 3) + " (a model is trained on one point set)");
  double extent = 0, largest = 0;
  for (std::size_t i = 0; i < run.X.size(); ++i) {
    extent = std::max(extent, std::abs(first_X[i]));
    largest = std::max(largest, std::abs(run.X[i] - first_X[i]));
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

TrainingData load_runs(const std::vector<std::string>& inputs, const std::function<void(const std::string&)>& on_file,
                       SnapshotFields fields) {
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
  TrainingData data;
  std::vector<double> first_X;
  std::string first_file;
  for (const auto& [file, test] : files) {
    if (on_file) on_file(file);
    RunSet& set = test ? data.test : data.train;
    set.runs.push_back(read_snapshot(file, fields));
    set.files.push_back(file);
    if (first_file.empty()) {
      first_X = set.runs.back().X;
      first_file = file;
    } else {
      require_same_reference(first_X, first_file, set.runs.back(), file);
    }
  }
  return data;
}

TrainingData load_training_data(const std::vector<std::string>& inputs,
                                const std::function<void(const std::string&)>& on_file, SnapshotFields fields) {
  TrainingData data = load_runs(inputs, on_file, fields);
  if (data.train.runs.empty()) throw std::runtime_error("no training runs among the inputs (all are test runs)");
  return data;
}

}  // namespace mpmrom
