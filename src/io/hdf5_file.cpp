#include "io/hdf5_file.hpp"

#include <hdf5.h>

#include <algorithm>
#include <functional>
#include <numeric>
#include <stdexcept>

namespace mpmrom::hdf5 {
namespace {

static_assert(std::is_same_v<hid_t, std::int64_t>, "Handle stores hid_t as int64_t (HDF5 1.10 or newer)");

// HDF5 chunks must stay below 4 GiB; growing datasets split larger entries along their first dimension.
constexpr hsize_t max_chunk_bytes = hsize_t(1) << 30;

// HDF5 would otherwise print its error stack to stderr for every failure, including those the callers handle.
void turn_off_error_printing() {
  static const bool turned_off = H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr) >= 0;
  (void)turned_off;
}

// The innermost message of HDF5's error stack, the most specific one, e.g. "file signature not found".
std::string innermost_reason() {
  std::string reason = "unknown HDF5 error";
  const H5E_walk2_t keep_last = [](unsigned, const H5E_error2_t* error, void* data) -> herr_t {
    if (error->desc != nullptr && *error->desc != '\0') *static_cast<std::string*>(data) = error->desc;
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, keep_last, &reason);
  H5Eclear2(H5E_DEFAULT);
  return reason;
}

[[noreturn]] void fail(const std::string& file_name, const std::string& action, const std::string& object) {
  throw std::runtime_error(file_name + ": cannot " + action + " " + object + ": " + innermost_reason());
}

[[noreturn]] void refuse(const std::string& file_name, const std::string& object, const std::string& problem) {
  throw std::runtime_error(file_name + ": " + object + " " + problem);
}

hid_t file_type(Element type) {
  if (type == Element::float32) return H5T_IEEE_F32LE;
  return type == Element::float64 ? H5T_IEEE_F64LE : H5T_STD_I64LE;
}

hid_t memory_type(Element type) {
  if (type == Element::float32) return H5T_NATIVE_FLOAT;
  return type == Element::float64 ? H5T_NATIVE_DOUBLE : H5T_NATIVE_INT64;
}

hsize_t element_bytes(Element type) { return type == Element::float32 ? 4 : 8; }

hsize_t product(const std::vector<hsize_t>& dims) {
  return std::accumulate(dims.begin(), dims.end(), hsize_t(1), std::multiplies<>());
}

std::string attribute_name(const Object& object, const std::string& name) {
  return "attribute '" + name + "' of " + object.path();
}

// UTF-8 strings of `width` bytes, NUL-padded (a string of exactly `width` bytes has no terminator).
Handle fixed_string_type(const std::string& file_name, const std::string& what, std::size_t width) {
  Handle type(H5Tcopy(H5T_C_S1));
  if (!type.is_open() || H5Tset_size(type.get(), width) < 0 || H5Tset_strpad(type.get(), H5T_STR_NULLPAD) < 0 ||
      H5Tset_cset(type.get(), H5T_CSET_UTF8) < 0) {
    fail(file_name, "make", "a string type for " + what);
  }
  return type;
}

void write_attribute(const Object& object, const std::string& name, hid_t type, hid_t space, const void* data) {
  const std::string what = attribute_name(object, name);
  const htri_t exists = H5Aexists(object.id(), name.c_str());
  if (exists < 0 || (exists > 0 && H5Adelete(object.id(), name.c_str()) < 0)) fail(object.file_name(), "replace", what);
  const Handle attribute(H5Acreate2(object.id(), name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT));
  if (!attribute.is_open() || (data != nullptr && H5Awrite(attribute.get(), type, data) < 0)) {
    fail(object.file_name(), "write", what);
  }
}

// An open attribute with its type and element count.
struct OpenAttribute {
  Handle attribute;
  Handle type;
  hssize_t count = 0;
};

OpenAttribute open_attribute(const Object& object, const std::string& name) {
  const std::string what = attribute_name(object, name);
  const htri_t exists = H5Aexists(object.id(), name.c_str());
  if (exists < 0) fail(object.file_name(), "look for", what);
  if (exists == 0) refuse(object.file_name(), what, "is missing");
  OpenAttribute open{Handle(H5Aopen(object.id(), name.c_str(), H5P_DEFAULT)), Handle(), 0};
  if (!open.attribute.is_open()) fail(object.file_name(), "open", what);
  open.type = Handle(H5Aget_type(open.attribute.get()));
  const Handle space(H5Aget_space(open.attribute.get()));
  open.count = space.is_open() ? H5Sget_simple_extent_npoints(space.get()) : -1;
  if (!open.type.is_open() || open.count < 0) fail(object.file_name(), "inspect", what);
  return open;
}

bool legacy_strings_trusted = false;

// Groups must keep their links in their object header (HDF5 1.8's layout, which mpmrom writes). The older layout, a
// symbol table with a local heap, is where a damaged free list sent libhdf5 1.10 into an endless allocation loop
// (found by fuzzing: 24 GB in 89 s, inside H5Gopen2); files of older mpmrom versions have it and are opened only
// inside TrustLegacyStrings (mpmrom upgrade).
void require_header_links(const std::string& file_name, hid_t group, const std::string& path) {
  if (legacy_strings_trusted) return;
  unsigned version = 0;
#if H5_VERSION_GE(1, 12, 0)
  H5O_native_info_t info;
  const herr_t status = H5Oget_native_info(group, &info, H5O_NATIVE_INFO_HDR);
#else
  H5O_info_t info;
  const herr_t status = H5Oget_info2(group, &info, H5O_INFO_HDR);
#endif
  if (status < 0) fail(file_name, "inspect", "group " + path);
  version = info.hdr.version;
  H5G_info_t links;
  if (version < 2 || H5Gget_info(group, &links) < 0 || links.storage_type == H5G_STORAGE_TYPE_SYMBOL_TABLE)
    refuse(file_name, "group " + path,
           "has the HDF5 layout of older mpmrom versions (a symbol table): the file was written by an older mpmrom; "
           "if it comes from a source you trust, convert it with 'mpmrom upgrade " +
               file_name + "'");
}

// The attribute's strings. Fixed-length ones are read into a buffer bounded by the bytes the attribute stores.
// Variable-length ones (files of mpmrom before format versions snapshot 2, model 2, ROM 3) live in the file's
// global heap, which libhdf5 1.10 follows without checks: a damaged file can hang or crash it (found by fuzzing), so
// they are read only inside TrustLegacyStrings.
std::vector<std::string> read_string_attribute(const Object& object, const std::string& name) {
  const OpenAttribute open = open_attribute(object, name);
  const std::string what = attribute_name(object, name);
  if (H5Tget_class(open.type.get()) != H5T_STRING) refuse(object.file_name(), what, "is not a string");
  const std::size_t count = static_cast<std::size_t>(open.count);
  const htri_t variable = H5Tis_variable_str(open.type.get());
  if (variable < 0) fail(object.file_name(), "inspect", what);
  if (variable > 0) {
    if (!legacy_strings_trusted)
      refuse(object.file_name(), what,
             "is a variable-length string: the file was written by an older mpmrom; if it comes from a source you "
             "trust, convert it with 'mpmrom upgrade " +
                 object.file_name() + "'");
    const Handle type(H5Tcopy(open.type.get()));
    std::vector<char*> values(count, nullptr);
    const herr_t status = values.empty() ? 0 : H5Aread(open.attribute.get(), type.get(), values.data());
    std::vector<std::string> result;
    for (char* value : values) {  // freed also after a failed read, which may have converted some of them
      result.emplace_back(value != nullptr ? value : "");
      H5free_memory(value);
    }
    if (status < 0) fail(object.file_name(), "read", what);
    return result;
  }
  const std::size_t width = H5Tget_size(open.type.get());
  if (width == 0) fail(object.file_name(), "inspect", what);
  if (H5Aget_storage_size(open.attribute.get()) < count * width) refuse(object.file_name(), what, "is truncated");
  // Read through the same width with NUL padding, whatever padding the file declares.
  const Handle type = fixed_string_type(object.file_name(), what, width);
  std::vector<char> buffer(count * width);
  if (!buffer.empty() && H5Aread(open.attribute.get(), type.get(), buffer.data()) < 0)
    fail(object.file_name(), "read", what);
  std::vector<std::string> result;
  for (std::size_t i = 0; i < count; ++i) {
    const char* entry = buffer.data() + i * width;
    result.emplace_back(entry, std::find(entry, entry + width, '\0'));
  }
  return result;
}

// Whether a stored numeric type is a standard little-endian one (mpmrom writes float32, float64 and int64). Checked
// before HDF5 converts anything through it: a damaged type description (bit offsets, precision) sent libhdf5 1.10's
// conversion to a wild address (found by fuzzing).
bool standard_number_type(hid_t type, bool integer_only) {
  const hid_t integers[] = {H5T_STD_I64LE, H5T_STD_I32LE};
  for (const hid_t known : integers)
    if (H5Tequal(type, known) > 0) return true;
  return !integer_only && (H5Tequal(type, H5T_IEEE_F64LE) > 0 || H5Tequal(type, H5T_IEEE_F32LE) > 0);
}

OpenAttribute open_scalar_attribute(const Object& object, const std::string& name, bool integer_only) {
  OpenAttribute open = open_attribute(object, name);
  if (!standard_number_type(open.type.get(), integer_only) || open.count != 1) {
    refuse(object.file_name(), attribute_name(object, name), integer_only ? "is not an integer" : "is not a number");
  }
  return open;
}

std::vector<hsize_t> dataset_dims(const Object& dataset, const Handle& space) {
  const int rank = space.is_open() ? H5Sget_simple_extent_ndims(space.get()) : -1;
  std::vector<hsize_t> dims(std::max(rank, 0));
  if (rank < 0 || H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr) < 0) {
    fail(dataset.file_name(), "read the shape of", "dataset " + dataset.path());
  }
  return dims;
}

}  // namespace

Handle::~Handle() { release(); }

Handle::Handle(Handle&& other) noexcept : id_(std::exchange(other.id_, -1)) {}

Handle& Handle::operator=(Handle&& other) noexcept {
  if (this != &other) {
    release();
    id_ = std::exchange(other.id_, -1);
  }
  return *this;
}

bool Handle::release() {
  if (id_ < 0) return true;
  const bool released = H5Idec_ref(id_) >= 0;
  id_ = -1;
  return released;
}

void Object::close() {
  if (!handle_.release()) fail(file_name_, "close", path_);
}

std::string Object::child_path(const std::string& name) const { return path_ == "/" ? "/" + name : path_ + "/" + name; }

bool Object::has_attribute(const std::string& name) const {
  const htri_t exists = H5Aexists(id(), name.c_str());
  if (exists < 0) fail(file_name_, "look for", attribute_name(*this, name));
  return exists > 0;
}

void Object::set_string_attribute(const std::string& name, const std::string& value) {
  const std::size_t width = std::max<std::size_t>(value.size(), 1);  // HDF5 has no zero-width strings
  const Handle type = fixed_string_type(file_name_, attribute_name(*this, name), width);
  const Handle space(H5Screate(H5S_SCALAR));
  std::string padded = value;
  padded.resize(width, '\0');
  write_attribute(*this, name, type.get(), space.get(), padded.data());
}

void Object::set_string_list_attribute(const std::string& name, const std::vector<std::string>& values) {
  std::size_t width = 1;
  for (const auto& value : values) width = std::max(width, value.size());
  const Handle type = fixed_string_type(file_name_, attribute_name(*this, name), width);
  const hsize_t count = values.size();
  const Handle space(H5Screate_simple(1, &count, nullptr));
  std::vector<char> data(values.size() * width, '\0');
  for (std::size_t i = 0; i < values.size(); ++i)
    std::copy(values[i].begin(), values[i].end(), data.begin() + long(i * width));
  write_attribute(*this, name, type.get(), space.get(), data.empty() ? nullptr : data.data());
}

void Object::set_double_attribute(const std::string& name, double value) {
  const Handle space(H5Screate(H5S_SCALAR));
  write_attribute(*this, name, H5T_NATIVE_DOUBLE, space.get(), &value);
}

void Object::set_integer_attribute(const std::string& name, std::int64_t value) {
  const Handle space(H5Screate(H5S_SCALAR));
  write_attribute(*this, name, H5T_NATIVE_INT64, space.get(), &value);
}

void Object::remove_attribute(const std::string& name) {
  if (H5Adelete(id(), name.c_str()) < 0) fail(file_name_, "remove", attribute_name(*this, name));
}

std::string Object::string_attribute(const std::string& name) const {
  auto values = read_string_attribute(*this, name);
  if (values.size() != 1) refuse(file_name_, attribute_name(*this, name), "is not a single string");
  return std::move(values.front());
}

std::vector<std::string> Object::string_list_attribute(const std::string& name) const {
  return read_string_attribute(*this, name);
}

TrustLegacyStrings::TrustLegacyStrings() : previous_(legacy_strings_trusted) { legacy_strings_trusted = true; }
TrustLegacyStrings::~TrustLegacyStrings() { legacy_strings_trusted = previous_; }

double Object::double_attribute(const std::string& name) const {
  const OpenAttribute open = open_scalar_attribute(*this, name, false);
  double value = 0;
  if (H5Aread(open.attribute.get(), H5T_NATIVE_DOUBLE, &value) < 0) {
    fail(file_name_, "read", attribute_name(*this, name));
  }
  return value;
}

std::int64_t Object::integer_attribute(const std::string& name) const {
  const OpenAttribute open = open_scalar_attribute(*this, name, true);
  std::int64_t value = 0;
  if (H5Aread(open.attribute.get(), H5T_NATIVE_INT64, &value) < 0) {
    fail(file_name_, "read", attribute_name(*this, name));
  }
  return value;
}

std::vector<std::size_t> Dataset::shape() const {
  const auto dims = dataset_dims(*this, Handle(H5Dget_space(id())));
  return {dims.begin(), dims.end()};
}

void Dataset::write_from(const void* data, Element type) {
  if (H5Dwrite(id(), memory_type(type), H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    fail(file_name_, "write", "dataset " + path_);
  }
}

void Dataset::append_from(const void* entry, Element type) {
  auto dims = dataset_dims(*this, Handle(H5Dget_space(id())));
  if (dims.empty()) refuse(file_name_, "dataset " + path_, "is a scalar and cannot grow");
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  start[0] = dims[0];
  count[0] = 1;
  dims[0] += 1;
  if (H5Dset_extent(id(), dims.data()) < 0) fail(file_name_, "grow", "dataset " + path_);
  const Handle file_space(H5Dget_space(id()));
  // The memory space has the shape of the file selection: HDF5 then maps it to the chunk in one piece instead of
  // element by element.
  const Handle memory_space(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr));
  if (!file_space.is_open() || !memory_space.is_open() ||
      H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) < 0 ||
      H5Dwrite(id(), memory_type(type), memory_space.get(), file_space.get(), H5P_DEFAULT, entry) < 0) {
    fail(file_name_, "append to", "dataset " + path_);
  }
}

std::vector<double> Dataset::read() const {
  const auto dims = dataset_dims(*this, Handle(H5Dget_space(id())));
  check_readable(std::size_t(product(dims)));
  std::vector<double> values(product(dims));
  if (!values.empty() && H5Dread(id(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0) {
    fail(file_name_, "read", "dataset " + path_);
  }
  return values;
}

std::vector<double> Dataset::read_entry(std::size_t index) const {
  const Handle file_space(H5Dget_space(id()));
  const auto dims = dataset_dims(*this, file_space);
  check_readable(std::size_t(product(dims)));
  if (dims.empty() || index >= dims[0])
    refuse(file_name_, "dataset " + path_, "has no entry " + std::to_string(index) + " along its first dimension");
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  start[0] = hsize_t(index);
  count[0] = 1;
  std::vector<double> values(product(count));
  const Handle memory_space(H5Screate_simple(int(count.size()), count.data(), nullptr));
  if (!values.empty() &&
      (!memory_space.is_open() ||
       H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) < 0 ||
       H5Dread(id(), H5T_NATIVE_DOUBLE, memory_space.get(), file_space.get(), H5P_DEFAULT, values.data()) < 0))
    fail(file_name_, "read", "dataset " + path_);
  return values;
}

void Dataset::check_readable(std::size_t elements) const {
  // A damaged file can claim more elements than it stores (libhdf5 1.10 then reads past its own buffers, found by
  // fuzzing) or than it could hold (this buffer would be the allocation it asks for): both refused before reading.
  const Handle stored_type(H5Dget_type(id()));
  const Handle file(H5Iget_file_id(id()));
  hsize_t file_size = 0;
  if (!stored_type.is_open() || !file.is_open() || H5Fget_filesize(file.get(), &file_size) < 0)
    fail(file_name_, "inspect", "dataset " + path_);
  if (!standard_number_type(stored_type.get(), false))
    refuse(file_name_, "dataset " + path_, "does not hold numbers of a standard type (float32, float64, int32, int64)");
  const double required = double(elements) * double(H5Tget_size(stored_type.get()));
  if (required > double(file_size)) refuse(file_name_, "dataset " + path_, "claims more data than the file holds");
  const Handle creation(H5Dget_create_plist(id()));
  if (!creation.is_open()) fail(file_name_, "inspect", "dataset " + path_);
  const bool view = H5Pget_layout(creation.get()) == H5D_VIRTUAL;  // stores nothing itself (the XDMF entry views)
  if (!view && double(H5Dget_storage_size(id())) < required)
    refuse(file_name_, "dataset " + path_, "is truncated or unwritten");
}

std::vector<std::string> Dataset::read_strings() const {
  const Handle stored_type(H5Dget_type(id()));
  if (!stored_type.is_open()) fail(file_name_, "inspect", "dataset " + path_);
  if (H5Tget_class(stored_type.get()) != H5T_STRING || H5Tis_variable_str(stored_type.get()) != 0) {
    refuse(file_name_, "dataset " + path_, "is not a list of fixed-length strings");
  }
  const auto dims = dataset_dims(*this, Handle(H5Dget_space(id())));
  if (dims.size() != 1) refuse(file_name_, "dataset " + path_, "is not a vector of strings");
  const std::size_t width = H5Tget_size(stored_type.get());
  if (width == 0) fail(file_name_, "inspect", "dataset " + path_);
  // The stored bytes bound the allocation: a damaged shape cannot make this reader ask for more than the file holds.
  if (H5Dget_storage_size(id()) < dims[0] * width) refuse(file_name_, "dataset " + path_, "is truncated or unwritten");
  // Read through the same width with NUL padding, whatever padding the file declares.
  const Handle type = fixed_string_type(file_name_, "dataset " + path_, width);
  std::vector<char> buffer(dims[0] * width);
  if (!buffer.empty() && H5Dread(id(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer.data()) < 0) {
    fail(file_name_, "read", "dataset " + path_);
  }
  std::vector<std::string> values;
  values.reserve(dims[0]);
  for (std::size_t i = 0; i < dims[0]; ++i) {
    const char* entry = buffer.data() + i * width;
    values.emplace_back(entry, std::find(entry, entry + width, '\0'));
  }
  return values;
}

Group Group::create_group(const std::string& name) {
  Handle handle(H5Gcreate2(id(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!handle.is_open()) fail(file_name_, "create", "group " + child_path(name));
  return Group(std::move(handle), file_name_, child_path(name));
}

bool Group::has_child(const std::string& name) const { return H5Lexists(id(), name.c_str(), H5P_DEFAULT) > 0; }

Group Group::group(const std::string& name) const {
  Handle handle(H5Gopen2(id(), name.c_str(), H5P_DEFAULT));
  if (!handle.is_open()) fail(file_name_, "open", "group " + child_path(name));
  require_header_links(file_name_, handle.get(), child_path(name));
  return Group(std::move(handle), file_name_, child_path(name));
}

Dataset Group::create_dataset(const std::string& name, Element type, const std::vector<std::size_t>& shape) {
  const std::vector<hsize_t> dims(shape.begin(), shape.end());
  const Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr));
  Handle dataset(H5Dcreate2(id(), name.c_str(), file_type(type), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!dataset.is_open()) fail(file_name_, "create", "dataset " + child_path(name));
  return Dataset(std::move(dataset), file_name_, child_path(name));
}

Dataset Group::create_string_list(const std::string& name, const std::vector<std::string>& values) {
  std::size_t width = 1;  // HDF5 has no zero-length string type
  for (const auto& value : values) width = std::max(width, value.size());
  const Handle type = fixed_string_type(file_name_, "dataset " + child_path(name), width);
  const hsize_t count = values.size();
  const Handle space(H5Screate_simple(1, &count, nullptr));
  Handle dataset(H5Dcreate2(id(), name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!dataset.is_open()) fail(file_name_, "create", "dataset " + child_path(name));
  std::vector<char> buffer(values.size() * width, '\0');
  for (std::size_t i = 0; i < values.size(); ++i) std::copy(values[i].begin(), values[i].end(), &buffer[i * width]);
  if (!buffer.empty() && H5Dwrite(dataset.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer.data()) < 0) {
    fail(file_name_, "write", "dataset " + child_path(name));
  }
  return Dataset(std::move(dataset), file_name_, child_path(name));
}

Dataset Group::create_growing_dataset(const std::string& name, Element type,
                                      const std::vector<std::size_t>& entry_shape) {
  std::vector<hsize_t> dims{0}, max_dims{H5S_UNLIMITED}, chunk{1};
  for (const std::size_t extent : entry_shape) {
    dims.push_back(extent);
    max_dims.push_back(extent);
    chunk.push_back(extent);
  }
  if (chunk.size() > 1) {
    const hsize_t row_bytes = std::accumulate(chunk.begin() + 2, chunk.end(), element_bytes(type), std::multiplies<>());
    chunk[1] =
        std::clamp<hsize_t>(max_chunk_bytes / std::max<hsize_t>(row_bytes, 1), 1, std::max<hsize_t>(chunk[1], 1));
  }
  const Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), max_dims.data()));
  const Handle properties(H5Pcreate(H5P_DATASET_CREATE));
  // Every chunk is written whole by append, so HDF5 need not write fill values into it first.
  if (!space.is_open() || !properties.is_open() ||
      H5Pset_chunk(properties.get(), static_cast<int>(chunk.size()), chunk.data()) < 0 ||
      H5Pset_fill_time(properties.get(), H5D_FILL_TIME_NEVER) < 0) {
    fail(file_name_, "prepare", "dataset " + child_path(name));
  }
  Handle dataset(
      H5Dcreate2(id(), name.c_str(), file_type(type), space.get(), H5P_DEFAULT, properties.get(), H5P_DEFAULT));
  if (!dataset.is_open()) fail(file_name_, "create", "dataset " + child_path(name));
  return Dataset(std::move(dataset), file_name_, child_path(name));
}

Dataset Group::create_entry_view(const std::string& name, const Dataset& source,
                                 const std::vector<std::size_t>& index) {
  const Handle source_space(H5Dget_space(source.id()));
  const auto source_dims = dataset_dims(source, source_space);
  std::string index_text;
  for (const std::size_t i : index) index_text += (index_text.empty() ? "" : ", ") + std::to_string(i);
  bool inside = !index.empty() && index.size() < source_dims.size();
  for (std::size_t d = 0; inside && d < index.size(); ++d) inside = index[d] < source_dims[d];
  if (!inside) refuse(file_name_, "dataset " + source.path(), "has no entry (" + index_text + ") to view");
  std::vector<hsize_t> start(source_dims.size(), 0), count = source_dims;
  for (std::size_t d = 0; d < index.size(); ++d) {
    start[d] = index[d];
    count[d] = 1;
  }
  const std::vector<hsize_t> view_dims(source_dims.begin() + std::ptrdiff_t(index.size()), source_dims.end());
  const Handle view_space(H5Screate_simple(static_cast<int>(view_dims.size()), view_dims.data(), nullptr));
  const Handle type(H5Dget_type(source.id()));
  const Handle properties(H5Pcreate(H5P_DATASET_CREATE));
  // "." names the file holding the view itself, so the mapping survives renaming or moving the file.
  if (!view_space.is_open() || !type.is_open() || !properties.is_open() ||
      H5Sselect_hyperslab(source_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) < 0 ||
      H5Pset_virtual(properties.get(), view_space.get(), ".", source.path().c_str(), source_space.get()) < 0) {
    fail(file_name_, "prepare", "virtual dataset " + child_path(name));
  }
  Handle dataset(
      H5Dcreate2(id(), name.c_str(), type.get(), view_space.get(), H5P_DEFAULT, properties.get(), H5P_DEFAULT));
  if (!dataset.is_open()) fail(file_name_, "create", "virtual dataset " + child_path(name));
  return Dataset(std::move(dataset), file_name_, child_path(name));
}

Dataset Group::dataset(const std::string& name) const {
  Handle dataset(H5Dopen2(id(), name.c_str(), H5P_DEFAULT));
  if (!dataset.is_open()) fail(file_name_, "open", "dataset " + child_path(name));
  return Dataset(std::move(dataset), file_name_, child_path(name));
}

void Group::remove(const std::string& name) {
  if (H5Ldelete(id(), name.c_str(), H5P_DEFAULT) < 0) fail(file_name_, "remove", child_path(name));
}

File File::create(const std::string& file_name) {
  turn_off_error_printing();
  // HDF5 1.8's layout or newer: groups keep their links in their object headers (see require_header_links).
  const Handle access(H5Pcreate(H5P_FILE_ACCESS));
  if (!access.is_open() || H5Pset_libver_bounds(access.get(), H5F_LIBVER_V18, H5F_LIBVER_V110) < 0)
    fail(file_name, "set up", "the HDF5 file's format");
  Handle file(H5Fcreate(file_name.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, access.get()));
  if (!file.is_open()) fail(file_name, "create", "the HDF5 file");
  return File(std::move(file), file_name, "/");
}

File File::open(const std::string& file_name, Mode mode) {
  turn_off_error_printing();
  Handle file(H5Fopen(file_name.c_str(), mode == Mode::read_only ? H5F_ACC_RDONLY : H5F_ACC_RDWR, H5P_DEFAULT));
  if (!file.is_open()) fail(file_name, "open", "as an HDF5 file");
  require_header_links(file_name, file.get(), "/");
  return File(std::move(file), file_name, "/");
}

}  // namespace mpmrom::hdf5
