#include "io/file_checks.hpp"

#include <filesystem>
#include <system_error>

#include "mpmrom/mpmrom_config.hpp"
#include "mpmrom/runtime.hpp"

namespace mpmrom::impl {

void write_file_identity(hdf5::File& file, const std::string& format, int format_version) {
  file.set_string_attribute("format", format);
  file.set_integer_attribute("format_version", format_version);
  file.set_string_attribute("precision", MPMROM_PRECISION_NAME);
  file.set_string_attribute("mpmrom_version", MPMROM_VERSION_STRING);
  file.set_string_attribute("git_commit", git_commit());
}

hdf5::File open_checked(const std::string& path, const FileKind& kind, std::int64_t* version) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) bad(path, kind.missing);
  hdf5::File file = hdf5::File::open(path);
  if (!file.has_attribute("format") || file.string_attribute("format") != kind.format) bad(path, kind.other_format);
  const std::int64_t found = file.integer_attribute("format_version");
  if (found < 1 || found > kind.newest_version)
    bad(path, kind.version_name + " format version " + std::to_string(found) +
                  " is not supported (this build reads versions 1 to " + std::to_string(kind.newest_version) + ")");
  if (!file.has_attribute("complete") || file.integer_attribute("complete") != 1) bad(path, kind.incomplete);
  if (version != nullptr) *version = found;
  return file;
}

std::vector<double> read_checked(const std::string& path, const hdf5::Dataset& dataset,
                                 const std::vector<std::size_t>& expected_shape, const std::string& expectation) {
  const auto shape = dataset.shape();
  if (shape != expected_shape) {
    bad(path, "dataset " + dataset.path() + " has shape " + shape_string(shape) + ", expected " +
                  shape_string(expected_shape) + " " + expectation);
  }
  auto values = dataset.read();
  require_finite(path, "dataset " + dataset.path(), values.data(), shape);
  return values;
}

}  // namespace mpmrom::impl
