#include "mpmrom/snapshot.hpp"
#include "snapshots/snapshot_writer.hpp"

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numeric>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "io/file_checks.hpp"
#include "io/xdmf.hpp"
#include "mpmrom/runtime.hpp"

namespace mpmrom {
namespace {

using impl::bad;
using impl::number_string;
using impl::product;
using impl::read_checked;
using impl::require_finite;
using impl::require_positive;
using impl::shape_string;

constexpr hdf5::Element stored_element = hdf5::element_of<real_t>();

// Checks everything the constructor is given before any file is created; returns num_points.
std::size_t validated_num_points(const std::string& path, const SnapshotHeader& header, std::size_t num_points,
                                 const real_t* X, const real_t* mass, const real_t* volume) {
  if (xdmf_path_for(path) == path) bad(path, "a snapshot cannot have the extension .xmf of its XDMF side file");
  if (num_points == 0) bad(path, "a snapshot needs at least one material point");
  if (!std::isfinite(header.dx) || header.dx <= 0) {
    bad(path, "grid spacing dx = " + number_string(header.dx) + " is not positive");
  }
  std::set<std::string> names;
  for (const auto& [name, value] : header.parameters) {
    if (name.empty() || !names.insert(name).second) {
      bad(path, "parameter names must be non-empty and unique ('" + name + "')");
    }
    if (!std::isfinite(value)) bad(path, "parameter '" + name + "' is not finite");
  }
  require_finite(path, "X", X, {num_points, 3});
  require_finite(path, "mass", mass, {num_points});
  require_finite(path, "volume", volume, {num_points});
  require_positive(path, "mass", mass, num_points);
  require_positive(path, "volume", volume, num_points);
  return num_points;
}

// The side file's arrays: positions, velocity and F per frame (views /xdmf/<array>/<frame>), X and mass.
std::vector<impl::XdmfBlock> xdmf_blocks(const std::string& scene_name) {
  constexpr int bytes = int(sizeof(real_t));
  return {{scene_name,
           "/xdmf/x",
           bytes,
           {{"velocity", 3, bytes, "/xdmf/v", true},
            {"F", 9, bytes, "/xdmf/F", true},
            {"X", 3, bytes, "/reference/X", false},
            {"mass", 1, bytes, "/reference/mass", false}}}};
}

// The datasets the side file refers to: the vertex list and, per frame k, views /xdmf/x/k, /xdmf/v/k and /xdmf/F/k.
void write_xdmf_views(hdf5::File& file, std::size_t num_points, std::size_t num_frames,
                      const std::vector<const hdf5::Dataset*>& sources) {
  hdf5::Group xdmf = file.create_group("xdmf");
  impl::write_xdmf_vertices(xdmf, num_points);
  for (const hdf5::Dataset* source : sources) {
    hdf5::Group views = xdmf.create_group(source->path().substr(1));  // "/x" -> "x"
    for (std::size_t frame = 0; frame < num_frames; ++frame) {
      views.create_entry_view(std::to_string(frame), *source, {frame});
    }
  }
}

}  // namespace

std::string xdmf_path_for(const std::string& snapshot_path) {
  return std::filesystem::path(snapshot_path).replace_extension(".xmf").string();
}

SnapshotWriter::SnapshotWriter(const std::string& path, const SnapshotHeader& header, std::size_t num_points,
                               const real_t* X, const real_t* mass, const real_t* volume)
    : path_(path),
      scene_name_(header.scene_name),
      num_points_(validated_num_points(path, header, num_points, X, mass, volume)),
      h5_(path),
      xdmf_(xdmf_path_for(path)),
      file_(hdf5::File::create(h5_.temporary_path())),
      time_(file_.create_growing_dataset("time", hdf5::Element::float64, {})),
      x_(file_.create_growing_dataset("x", stored_element, {num_points, 3})),
      v_(file_.create_growing_dataset("v", stored_element, {num_points, 3})),
      F_(file_.create_growing_dataset("F", stored_element, {num_points, 3, 3})),
      C_(file_.create_growing_dataset("C", stored_element, {num_points, 3, 3})) {
  impl::write_file_identity(file_, snapshot_format, snapshot_format_version);
  file_.set_string_attribute("scene_name", header.scene_name);
  file_.set_string_attribute("scene", header.scene_text);
  file_.set_double_attribute("dx", header.dx);
  hdf5::Group parameters = file_.create_group("parameters");
  std::vector<std::string> names;
  for (const auto& [name, value] : header.parameters) {
    parameters.set_double_attribute(name, value);
    names.push_back(name);
  }
  // Attributes of a group have no guaranteed order, so the order lives in its own list.
  file_.set_string_list_attribute("parameter_names", names);
  hdf5::Group reference = file_.create_group("reference");
  reference.create_dataset("X", stored_element, {num_points, 3}).write(X);
  reference.create_dataset("mass", stored_element, {num_points}).write(mass);
  reference.create_dataset("volume", stored_element, {num_points}).write(volume);
}

void SnapshotWriter::require_open(const char* action) const {
  if (state_ == State::committed) throw std::logic_error(path_ + ": cannot " + action + " a committed snapshot");
  if (state_ == State::failed) {
    throw std::logic_error(path_ + ": cannot " + action + " a snapshot after a failed write");
  }
}

void SnapshotWriter::append(double time, const real_t* x, const real_t* v, const real_t* F, const real_t* C) {
  require_open("append to");
  const std::string frame = "frame " + std::to_string(times_.size()) + " (t = " + number_string(time) + ")";
  if (!std::isfinite(time)) bad(path_, frame + ": the time is not finite");
  if (!times_.empty() && time <= times_.back()) {
    bad(path_, frame + " is not after the previous frame (t = " + number_string(times_.back()) + ")");
  }
  require_finite(path_, frame + ": x", x, {num_points_, 3});
  require_finite(path_, frame + ": v", v, {num_points_, 3});
  require_finite(path_, frame + ": F", F, {num_points_, 3, 3});
  require_finite(path_, frame + ": C", C, {num_points_, 3, 3});
  state_ = State::failed;  // until every dataset has its entry
  time_.append(&time);
  x_.append(x);
  v_.append(v);
  F_.append(F);
  C_.append(C);
  times_.push_back(time);
  state_ = State::open;
}

std::string failed_path_for(const std::string& snapshot_path) {
  return std::filesystem::path(snapshot_path).replace_extension(".failed.h5").string();
}

void SnapshotWriter::commit() { finish(path_, ""); }

std::string SnapshotWriter::commit_failed(const std::string& failure) {
  const std::string path = failed_path_for(path_);
  finish(path, failure);
  return path;
}

void SnapshotWriter::finish(const std::string& h5_path, const std::string& failure) {
  require_open("commit");
  state_ = State::failed;
  write_xdmf_views(file_, num_points_, times_.size(), {&x_, &v_, &F_});
  file_.set_integer_attribute("complete", failure.empty() ? 1 : 0);
  if (!failure.empty()) file_.set_string_attribute("failure", failure);
  // Every object closed first, so that closing the file really closes it and reports a failed final flush.
  for (hdf5::Dataset* dataset : {&time_, &x_, &v_, &F_, &C_}) dataset->close();
  file_.close();
  std::ofstream xdmf(xdmf_.temporary_path(), std::ios::trunc);
  xdmf << impl::xdmf_text(std::filesystem::path(h5_path).filename().string(), scene_name_, num_points_, times_,
                          xdmf_blocks(scene_name_));
  xdmf.close();
  if (!xdmf) bad(xdmf_.temporary_path(), std::string("cannot write the XDMF side file: ") + std::strerror(errno));
  // The side file first: a snapshot under its final name always has its XDMF (a resumed sweep keeps such runs).
  xdmf_.commit_to(xdmf_path_for(h5_path));
  h5_.commit_to(h5_path);
  state_ = State::committed;
}

namespace {

// Opens a snapshot that is complete and of this build's format, else throws naming the problem.
hdf5::File open_complete_snapshot(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) bad(path, "no such snapshot file");
  hdf5::File file = hdf5::File::open(path);
  if (!file.has_attribute("format")) bad(path, "not an mpmrom snapshot (no 'format' attribute)");
  const std::string format = file.string_attribute("format");
  if (format != snapshot_format) bad(path, "not an mpmrom snapshot (format is '" + format + "')");
  const std::int64_t version = file.integer_attribute("format_version");
  // Version 1 differs in its string attributes only (variable-length), which the HDF5 layer refuses unless trusted.
  if (version < 1 || version > snapshot_format_version) {
    bad(path, "snapshot format version " + std::to_string(version) +
                  " is not supported (this build reads versions 1 to " + std::to_string(snapshot_format_version) + ")");
  }
  if (!file.has_attribute("complete") || file.integer_attribute("complete") != 1) {
    if (file.has_attribute("failure"))
      bad(path, "the frames of a run that failed: " + file.string_attribute("failure"));
    bad(path, "incomplete snapshot (the run did not finish)");
  }
  return file;
}

SnapshotHeader read_header(const hdf5::File& file, const std::string& path) {
  SnapshotHeader header;
  header.scene_name = file.string_attribute("scene_name");
  header.scene_text = file.string_attribute("scene");
  header.dx = file.double_attribute("dx");
  if (!std::isfinite(header.dx) || header.dx <= 0) {
    bad(path, "grid spacing dx = " + number_string(header.dx) + " is not positive");
  }
  const hdf5::Group parameters = file.group("parameters");
  std::set<std::string> seen;
  for (const std::string& name : file.string_list_attribute("parameter_names")) {
    if (!seen.insert(name).second) bad(path, "parameter '" + name + "' is listed twice");
    const double value = parameters.double_attribute(name);
    if (!std::isfinite(value)) bad(path, "parameter '" + name + "' is not finite");
    header.parameters.emplace_back(name, value);
  }
  return header;
}

}  // namespace

namespace {

// /reference of an open snapshot: X's shape, then X, mass and volume read and checked (positive masses and volumes).
SnapshotReference read_reference(const hdf5::File& file, const std::string& path) {
  const hdf5::Group reference = file.group("reference");
  const auto X_shape = reference.dataset("X").shape();
  if (X_shape.size() != 2 || X_shape[1] != 3 || X_shape[0] == 0)
    bad(path, "dataset /reference/X has shape " + shape_string(X_shape) + ", expected (points, 3) with points > 0");
  const std::size_t n = X_shape[0];
  const std::string expectation = "for " + std::to_string(n) + " points";
  SnapshotReference points{read_checked(path, reference.dataset("X"), {n, 3}, expectation),
                           read_checked(path, reference.dataset("mass"), {n}, expectation),
                           read_checked(path, reference.dataset("volume"), {n}, expectation)};
  require_positive(path, "/reference/mass", points.mass.data(), n);
  require_positive(path, "/reference/volume", points.volume.data(), n);
  return points;
}

}  // namespace

SnapshotReference read_snapshot_reference(const std::string& path) {
  return read_reference(open_complete_snapshot(path), path);
}

SnapshotHeader read_snapshot_header(const std::string& path) { return read_header(open_complete_snapshot(path), path); }

namespace {

// values (rows of `width` numbers) at the given rows only.
std::vector<double> rows_at(const std::vector<double>& values, std::size_t width,
                            const std::vector<std::size_t>& rows) {
  std::vector<double> kept;
  kept.reserve(rows.size() * width);
  for (const std::size_t row : rows)
    kept.insert(kept.end(), values.begin() + row * width, values.begin() + (row + 1) * width);
  return kept;
}

// A (frames, points, ...) field at the given points, read a frame at a time with read_checked's checks.
std::vector<double> field_at(const std::string& path, const hdf5::Dataset& dataset,
                             const std::vector<std::size_t>& expected_shape, const std::string& expectation,
                             const std::vector<std::size_t>& points) {
  const auto shape = dataset.shape();
  if (shape != expected_shape)
    bad(path, "dataset " + dataset.path() + " has shape " + shape_string(shape) + ", expected " +
                  shape_string(expected_shape) + " " + expectation);
  const std::vector<std::size_t> entry_shape(shape.begin() + 1, shape.end());
  const std::size_t width = product(entry_shape) / shape[1];
  std::vector<double> kept;
  kept.reserve(shape[0] * points.size() * width);
  for (std::size_t frame = 0; frame < shape[0]; ++frame) {
    const auto entry = dataset.read_entry(frame);
    require_finite(path, "dataset " + dataset.path() + " (frame " + std::to_string(frame) + ")", entry.data(),
                   entry_shape);
    for (const std::size_t p : points)
      kept.insert(kept.end(), entry.begin() + p * width, entry.begin() + (p + 1) * width);
  }
  return kept;
}

}  // namespace

Snapshot read_snapshot(const std::string& path, SnapshotFields fields, const std::vector<std::size_t>& points) {
  const hdf5::File file = open_complete_snapshot(path);
  Snapshot snapshot;
  snapshot.precision = file.string_attribute("precision");
  if (snapshot.precision != "float" && snapshot.precision != "double") {
    bad(path, "precision is '" + snapshot.precision + "', expected 'float' or 'double'");
  }
  snapshot.mpmrom_version = file.string_attribute("mpmrom_version");
  snapshot.git_commit = file.string_attribute("git_commit");
  snapshot.header = read_header(file, path);

  SnapshotReference reference = read_reference(file, path);
  const auto time_shape = file.dataset("time").shape();
  if (time_shape.size() != 1) bad(path, "dataset /time has shape " + shape_string(time_shape) + ", expected (frames)");
  const std::size_t n = reference.mass.size(), frames = time_shape[0];
  snapshot.num_points = n;
  snapshot.num_frames = frames;
  snapshot.X = std::move(reference.X);
  snapshot.mass = std::move(reference.mass);
  snapshot.volume = std::move(reference.volume);
  const std::string expectation = "for " + std::to_string(n) + " points and " + std::to_string(frames) + " frames";
  snapshot.time = read_checked(path, file.dataset("time"), {frames}, expectation);
  const auto read_field = [&](const char* name, std::vector<std::size_t> shape) {
    return points.empty() ? read_checked(path, file.dataset(name), shape, expectation)
                          : field_at(path, file.dataset(name), shape, expectation, points);
  };
  for (const std::size_t p : points)
    if (p >= n) bad(path, "point " + std::to_string(p) + " asked for, the run has " + std::to_string(n));
  snapshot.x = read_field("x", {frames, n, 3});
  snapshot.v = read_field("v", {frames, n, 3});
  snapshot.F = read_field("F", {frames, n, 3, 3});
  if (fields == SnapshotFields::All) {
    snapshot.C = read_field("C", {frames, n, 3, 3});
  } else if (const auto shape = file.dataset("C").shape(); shape != std::vector<std::size_t>{frames, n, 3, 3}) {
    bad(path, "dataset /C has shape " + shape_string(shape) + ", expected " + shape_string({frames, n, 3, 3}) + " " +
                  expectation);
  }
  for (std::size_t frame = 1; frame < frames; ++frame) {
    if (!(snapshot.time[frame] > snapshot.time[frame - 1])) {
      bad(path, "time of frame " + std::to_string(frame) + " is not after the previous frame's");
    }
  }
  if (!points.empty()) {
    snapshot.X = rows_at(snapshot.X, 3, points);
    snapshot.mass = rows_at(snapshot.mass, 1, points);
    snapshot.volume = rows_at(snapshot.volume, 1, points);
    snapshot.num_points = points.size();
    snapshot.point_ids = points;
  }
  return snapshot;
}

}  // namespace mpmrom
