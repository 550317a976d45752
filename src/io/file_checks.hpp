// Checks shared by the readers and writers of mpmrom's HDF5 files (snapshots, models): each failure is one line,
// "<file>: <problem>", thrown as std::runtime_error.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/hdf5_file.hpp"
#include "core/checked_integer.hpp"

namespace mpmrom::impl {

[[noreturn]] inline void bad(const std::string& path, const std::string& problem) {
  throw std::runtime_error(path + ": " + problem);
}

inline std::string number_string(double value, int digits = 6) {
  std::ostringstream out;
  out.precision(digits);
  out << value;
  return out.str();
}

inline std::size_t product(const std::vector<std::size_t>& shape) {
  return std::accumulate(shape.begin(), shape.end(), std::size_t(1), std::multiplies<>());
}

inline std::string shape_string(const std::vector<std::size_t>& shape) {
  std::string text = "(";
  for (std::size_t d = 0; d < shape.size(); ++d) text += (d > 0 ? ", " : "") + std::to_string(shape[d]);
  return text + ")";
}

// The row-major multi-index of flat element i, e.g. "(1, 17, 2)" for an array of shape (frames, points, 3).
inline std::string index_string(std::size_t i, const std::vector<std::size_t>& shape) {
  std::vector<std::size_t> index(shape.size());
  for (std::size_t d = shape.size(); d-- > 0;) {
    index[d] = i % shape[d];
    i /= shape[d];
  }
  return shape_string(index);
}

template <class T>
void require_finite(const std::string& path, const std::string& what, const T* values,
                    const std::vector<std::size_t>& shape) {
  const std::size_t count = product(shape);
  for (std::size_t i = 0; i < count; ++i) {
    if (!std::isfinite(values[i])) {
      bad(path, what + " holds a non-finite value (" + number_string(values[i]) + ") at " + index_string(i, shape));
    }
  }
}

template <class T>
void require_positive(const std::string& path, const std::string& what, const T* values, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    if (!(values[i] > 0)) {
      bad(path, what + " of point " + std::to_string(i) + " is not positive (" + number_string(values[i]) + ")");
    }
  }
}

// Whole numbers a file stores (read as doubles) as Integer, each checked to lie in [lo, hi] (impl::checked_integer):
// a damaged file must not reach an undefined conversion. The error names the file, the dataset and the entry.
template <class Integer>
std::vector<Integer> checked_integers(const std::string& path, const std::string& what,
                                      const std::vector<double>& values, double lo = -INFINITY, double hi = INFINITY) {
  std::vector<Integer> integers(values.size());
  for (std::size_t i = 0; i < values.size(); ++i)
    integers[i] = checked_integer<Integer>(
        values[i], [&] { return path + ": " + what + " entry " + std::to_string(i); }, lo, hi);
  return integers;
}

// The identity every mpmrom file carries: format tag and version, precision, and the build that wrote it.
void write_file_identity(hdf5::File& file, const std::string& format, int format_version);

// What a reader expects of a kind of file before reading it (write_file_identity), and its errors when the file is not
// that: absent, of another format, of a format version it does not read, or not completely written.
struct FileKind {
  std::string format;        // the "format" attribute
  int newest_version;        // versions 1 to newest_version are read
  std::string version_name;  // "<version_name> format version 4 is not supported ..."
  std::string missing, other_format, incomplete;
};

// Opens the file at path after checking it against kind, in the order of FileKind's errors; version, if given,
// receives the file's format version.
hdf5::File open_checked(const std::string& path, const FileKind& kind, std::int64_t* version = nullptr);

// Reads a dataset after checking its shape, and checks that every value is finite.
std::vector<double> read_checked(const std::string& path, const hdf5::Dataset& dataset,
                                 const std::vector<std::size_t>& expected_shape, const std::string& expectation);

}  // namespace mpmrom::impl
