// Rollout checkpoints (rom/detail/rom_stepper.hpp): HDF5 files with the batch's state at an output frame.
#include <cstdint>
#include <filesystem>
#include <string>
#include <type_traits>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/hdf5_file.hpp"
#include "io/file_checks.hpp"
#include "rom/detail/rollout_driver.hpp"

namespace mpmrom::impl {
namespace {

constexpr const char* checkpoint_format = "mpmrom-rom-checkpoint";
constexpr int checkpoint_format_version = 1;

template <class T>
void write_vector(hdf5::Group& group, const std::string& name, const std::vector<T>& values) {
  if constexpr (std::is_same_v<T, double>) {
    auto dataset = group.create_dataset(name, hdf5::Element::float64, std::vector<std::size_t>{values.size()});
    if (!values.empty()) dataset.write(values.data());
  } else {
    const std::vector<std::int64_t> wide(values.begin(), values.end());
    auto dataset = group.create_dataset(name, hdf5::Element::int64, std::vector<std::size_t>{wide.size()});
    if (!wide.empty()) dataset.write(wide.data());
  }
}

template <class T>
std::vector<T> read_vector(const std::string& path, const hdf5::Group& group, const std::string& name) {
  const hdf5::Dataset dataset = group.dataset(name);
  const auto shape = dataset.shape();
  if (shape.size() != 1) bad(path, "dataset /" + name + " of the checkpoint is not a vector");
  const auto values = read_checked(path, dataset, shape, "");
  if constexpr (std::is_integral_v<T>)
    return checked_integers<T>(path, "dataset /" + name + " of the checkpoint", values);
  else
    return values;
}

}  // namespace

void save_rollout_checkpoint(const std::string& path, const std::string& identity, const BatchState& state,
                             const RomResult& result) {
  AtomicFile out(path);
  {
    hdf5::File file = hdf5::File::create(out.temporary_path());
    write_file_identity(file, checkpoint_format, checkpoint_format_version);
    file.set_string_attribute("batch", identity);
    file.set_integer_attribute("frame", state.frame);
    file.set_integer_attribute("steps", state.steps);
    file.set_double_attribute("step_seconds", state.step_seconds);
    file.set_double_attribute("max_speed", state.max_speed);
    write_vector(file, "recorded_xhat", result.xhat);
    write_vector(file, "recorded_xhatdot", result.xhatdot);
    write_vector(file, "xhat", state.xhat);
    write_vector(file, "xhatdot", state.xhatdot);
    write_vector(file, "max_condition", state.max_condition);
    write_vector(file, "flags", state.flags);
    write_vector(file, "failures", state.failures);
    write_vector(file, "fallbacks", state.fallbacks);
    write_vector(file, "regularized", state.regularized);
    write_vector(file, "reference", state.reference);
    write_vector(file, "converged", state.converged);
    std::vector<int> completed, outcome_flags;
    std::vector<double> stopped;
    std::vector<std::string> messages;
    for (const auto& o : state.outcomes) {
      completed.push_back(o.frames_completed);
      outcome_flags.push_back(o.flags);
      stopped.push_back(o.stopped_at);
      messages.push_back(o.message);
    }
    write_vector(file, "frames_completed", completed);
    write_vector(file, "outcome_flags", outcome_flags);
    write_vector(file, "stopped_at", stopped);
    file.create_string_list("messages", messages);
    file.set_integer_attribute("complete", 1);
  }
  out.commit();
}

bool load_rollout_checkpoint(const std::string& path, const std::string& identity, BatchState& state,
                             RomResult& result) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) return false;
  const hdf5::File file = hdf5::File::open(path);
  if (!file.has_attribute("format") || file.string_attribute("format") != checkpoint_format)
    bad(path, "not an mpmrom rollout checkpoint");
  if (file.integer_attribute("format_version") != checkpoint_format_version)
    bad(path, "rollout checkpoint of another format version; remove it or run without --resume");
  if (!file.has_attribute("complete") || file.integer_attribute("complete") != 1) bad(path, "incomplete checkpoint");
  if (file.string_attribute("batch") != identity)
    bad(path,
        "is the checkpoint of another batch (model, scene, settings or parameters differ); remove it or run "
        "without --resume");
  state.frame = int(file.integer_attribute("frame"));
  state.steps = long(file.integer_attribute("steps"));
  state.step_seconds = file.double_attribute("step_seconds");
  state.max_speed = file.double_attribute("max_speed");
  const auto recorded_xhat = read_vector<double>(path, file, "recorded_xhat");
  const auto recorded_xhatdot = read_vector<double>(path, file, "recorded_xhatdot");
  if (recorded_xhat.size() != result.xhat.size() || recorded_xhatdot.size() != result.xhatdot.size())
    bad(path, "the recorded trajectories have another size than this batch's");
  result.xhat = recorded_xhat;
  result.xhatdot = recorded_xhatdot;
  state.xhat = read_vector<double>(path, file, "xhat");
  state.xhatdot = read_vector<double>(path, file, "xhatdot");
  state.max_condition = read_vector<double>(path, file, "max_condition");
  state.flags = read_vector<int>(path, file, "flags");
  state.failures = read_vector<int>(path, file, "failures");
  state.fallbacks = read_vector<int>(path, file, "fallbacks");
  state.regularized = read_vector<int>(path, file, "regularized");
  state.reference = read_vector<double>(path, file, "reference");
  state.converged = read_vector<int>(path, file, "converged");
  const auto completed = read_vector<int>(path, file, "frames_completed");
  const auto outcome_flags = read_vector<int>(path, file, "outcome_flags");
  const auto stopped = read_vector<double>(path, file, "stopped_at");
  const auto messages = file.dataset("messages").read_strings();
  if (completed.size() != outcome_flags.size() || completed.size() != stopped.size() ||
      completed.size() != messages.size())
    bad(path, "the outcome arrays differ in length");
  state.outcomes.assign(completed.size(), RolloutOutcome{});
  for (std::size_t b = 0; b < completed.size(); ++b) {
    state.outcomes[b].frames_completed = completed[b];
    state.outcomes[b].flags = outcome_flags[b];
    state.outcomes[b].stopped_at = stopped[b];
    state.outcomes[b].message = messages[b];
  }
  return true;
}

}  // namespace mpmrom::impl
