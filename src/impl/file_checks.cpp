#include "impl/file_checks.hpp"

namespace mpmrom::impl {

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
