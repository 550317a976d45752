#include "io/file_checks.hpp"

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
