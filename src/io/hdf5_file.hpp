// A small RAII layer over the HDF5 C API: files, groups, datasets and attributes close themselves, HDF5's automatic
// error printing is off, and every failure throws std::runtime_error with one line naming the file and the object,
// e.g. "run.h5: cannot open dataset /x: object 'x' doesn't exist". The header names no HDF5 type, so code that uses
// it needs no HDF5 headers (the library links HDF5 privately).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace mpmrom::hdf5 {

// Element type of a dataset in the file (stored little-endian).
enum class Element { float32, float64, int64 };

template <class T>
constexpr Element element_of() {
  static_assert(std::is_same_v<T, float> || std::is_same_v<T, double> || std::is_same_v<T, std::int64_t>,
                "datasets hold float, double or int64_t");
  if constexpr (std::is_same_v<T, float>) return Element::float32;
  if constexpr (std::is_same_v<T, double>) return Element::float64;
  return Element::int64;
}

// Owns one HDF5 identifier (hid_t, a 64-bit integer since HDF5 1.10) and releases it when destroyed.
class Handle {
 public:
  Handle() = default;
  explicit Handle(std::int64_t id) : id_(id) {}
  ~Handle();
  Handle(Handle&& other) noexcept;
  Handle& operator=(Handle&& other) noexcept;
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;

  std::int64_t get() const { return id_; }
  bool is_open() const { return id_ >= 0; }
  // Releases the identifier now; false if HDF5 reports a failure (for a file: the final flush).
  bool release();

 private:
  std::int64_t id_ = -1;
};

// Within its lifetime, string attributes stored as variable-length strings (files of older mpmrom versions) are read;
// outside it they are refused, since libhdf5 1.10 follows their global-heap references unchecked (a damaged file can
// hang or crash it). For `mpmrom upgrade`, which converts a file the user trusts. Not thread-safe.
class TrustLegacyStrings {
 public:
  TrustLegacyStrings();
  ~TrustLegacyStrings();
  TrustLegacyStrings(const TrustLegacyStrings&) = delete;
  TrustLegacyStrings& operator=(const TrustLegacyStrings&) = delete;

 private:
  bool previous_;
};

// A file, group or dataset: an object in a file that carries attributes.
class Object {
 public:
  const std::string& file_name() const { return file_name_; }
  const std::string& path() const { return path_; }  // inside the file; "/" for the root group
  std::int64_t id() const { return handle_.get(); }  // the hid_t, for HDF5 calls this layer does not wrap

  // Closes now and throws if HDF5 cannot (for a file: if the final flush fails). The destructor closes silently.
  void close();

  bool has_attribute(const std::string& name) const;
  // Setting an attribute replaces any attribute of that name. Strings are stored as fixed-length UTF-8 (NUL-padded
  // to the longest; variable-length ones are read only under TrustLegacyStrings).
  void set_string_attribute(const std::string& name, const std::string& value);
  void set_string_list_attribute(const std::string& name, const std::vector<std::string>& values);
  void set_double_attribute(const std::string& name, double value);
  void set_integer_attribute(const std::string& name, std::int64_t value);
  void remove_attribute(const std::string& name);
  std::string string_attribute(const std::string& name) const;
  std::vector<std::string> string_list_attribute(const std::string& name) const;
  double double_attribute(const std::string& name) const;  // from an integer or floating-point attribute
  std::int64_t integer_attribute(const std::string& name) const;

 protected:
  Object(Handle handle, std::string file_name, std::string path)
      : handle_(std::move(handle)), file_name_(std::move(file_name)), path_(std::move(path)) {}
  std::string child_path(const std::string& name) const;

  Handle handle_;
  std::string file_name_;
  std::string path_;
};

class Dataset : public Object {
 public:
  std::vector<std::size_t> shape() const;

  // The whole dataset from a row-major buffer of its shape, converted to the stored element type.
  template <class T>
  void write(const T* data) {
    write_from(data, element_of<T>());
  }
  // Grows the first dimension by one and writes that entry (shape()[1:] elements) in a single H5Dwrite. Only for
  // datasets made by Group::create_growing_dataset.
  template <class T>
  void append(const T* entry) {
    append_from(entry, element_of<T>());
  }
  // The whole dataset, row-major, converted to double whatever type it is stored in (int64 above 2^53 rounds).
  std::vector<double> read() const;
  // Entry `index` of the first dimension (shape()[1:] elements, row-major, as double): one frame of a (frames, ...)
  // dataset, read without the rest. Same checks as read().
  std::vector<double> read_entry(std::size_t index) const;
  // A dataset made by Group::create_string_list; refuses any other type (variable-length strings included).
  std::vector<std::string> read_strings() const;

 private:
  friend class Group;
  using Object::Object;
  void write_from(const void* data, Element memory_type);
  void append_from(const void* entry, Element memory_type);
  // Refuses a dataset of `elements` numbers that is not of a standard number type or that the file cannot hold.
  void check_readable(std::size_t elements) const;
};

class Group : public Object {
 public:
  Group create_group(const std::string& name);
  Group group(const std::string& name) const;
  bool has_child(const std::string& name) const;  // a group or dataset of that name directly under this group
  Dataset create_dataset(const std::string& name, Element type, const std::vector<std::size_t>& shape);
  // A vector of fixed-length UTF-8 strings (NUL-padded to the longest): unlike an attribute it has no 64 kB limit,
  // so it holds one string per rollout or run however many there are, and reading it allocates only its own size.
  Dataset create_string_list(const std::string& name, const std::vector<std::string>& values);
  // A dataset of shape (0, entry_shape...) that grows along its first dimension by Dataset::append, one entry per
  // chunk (entries over 1 GiB span several) so that each append is one contiguous write.
  Dataset create_growing_dataset(const std::string& name, Element type, const std::vector<std::size_t>& entry_shape);
  // A virtual dataset showing entry `index` along the leading dimensions of `source`, a dataset of the same file
  // (index {2, 5} of a (rollouts, frames, n, 3) array: rollout 2's frame 5): HDF5 stores the mapping, not a copy,
  // and readers see an ordinary dataset of shape source.shape()[index.size():].
  Dataset create_entry_view(const std::string& name, const Dataset& source, const std::vector<std::size_t>& index);
  Dataset dataset(const std::string& name) const;
  void remove(const std::string& name);  // unlinks a child; its space in the file is not reclaimed

 protected:
  using Object::Object;
};

class File : public Group {
 public:
  enum class Mode { read_only, read_write };
  static File create(const std::string& file_name);  // replaces an existing file
  static File open(const std::string& file_name, Mode mode = Mode::read_only);

 private:
  using Group::Group;
};

}  // namespace mpmrom::hdf5
