#include "analysis/upgrade.hpp"

#include <stdexcept>
#include <vector>

#include "io/hdf5_file.hpp"
#include "mpmrom/model.hpp"
#include "mpmrom/mpmrom_config.hpp"
#include "rom/rom_file.hpp"
#include "mpmrom/snapshot.hpp"
#include "snapshots/snapshot_writer.hpp"

namespace mpmrom {
namespace {

std::string versions(std::int64_t from, int to) {
  return " format " + std::to_string(from) + (from == to ? " (current already)" : " -> " + std::to_string(to));
}

void rewrite_snapshot(const std::string& path) {
  const Snapshot run = read_snapshot(path);
  const auto values = [](const std::vector<double>& all, std::size_t begin, std::size_t count) {
    return std::vector<real_t>(all.begin() + long(begin), all.begin() + long(begin + count));
  };
  const std::size_t n = run.num_points;
  const auto X = values(run.X, 0, 3 * n), mass = values(run.mass, 0, n), volume = values(run.volume, 0, n);
  SnapshotWriter writer(path, run.header, n, X.data(), mass.data(), volume.data());
  for (std::size_t f = 0; f < run.num_frames; ++f) {
    writer.append(run.time[f], values(run.x, 3 * n * f, 3 * n).data(), values(run.v, 3 * n * f, 3 * n).data(),
                  values(run.F, 9 * n * f, 9 * n).data(), values(run.C, 9 * n * f, 9 * n).data());
  }
  writer.commit();
}

}  // namespace

std::string upgrade_file(const std::string& path) {
  const hdf5::TrustLegacyStrings trust;
  std::string format;
  std::int64_t version = 0;
  bool checkpoint = false;
  {
    const hdf5::File file = hdf5::File::open(path);
    if (!file.has_attribute("format") || !file.has_attribute("format_version"))
      throw std::runtime_error(path + ": not an mpmrom file (no 'format' attribute)");
    format = file.string_attribute("format");
    version = file.integer_attribute("format_version");
    checkpoint = file.has_child("optimizer");
    // Files store their fields in the precision of the build that wrote them: rewriting must not narrow them.
    const std::string precision = file.has_attribute("precision") ? file.string_attribute("precision") : "";
    if (!precision.empty() && precision != MPMROM_PRECISION_NAME)
      throw std::runtime_error(path + ": a " + precision + "-precision file: upgrade it with a " + precision +
                               " build of mpmrom (this one is " + MPMROM_PRECISION_NAME + ")");
  }
  if (format == snapshot_format) {
    if (version < snapshot_format_version) rewrite_snapshot(path);
    return path + ": snapshot" + versions(version, snapshot_format_version);
  }
  if (format == model_format) {
    if (version < model_format_version) {
      OptimizerState state;
      const Model model = load_model(path, checkpoint ? &state : nullptr);
      save_model(path, model, checkpoint ? &state : nullptr);
    }
    return path + ": " + (checkpoint ? "training checkpoint" : "model") + versions(version, model_format_version);
  }
  if (format == rom_format) {
    if (version < rom_format_version) save_rom(path, load_rom(path));
    return path + ": ROM file" + versions(version, rom_format_version);
  }
  throw std::runtime_error(path + ": an mpmrom file of kind '" + format +
                           "', which upgrade does not convert (a rollout checkpoint: finish it with the build that "
                           "wrote it, or start the batch again)");
}

}  // namespace mpmrom
