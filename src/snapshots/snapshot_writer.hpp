// The writer of snapshot files (docs/snapshot_format.md), used by the full-order runs and file upgrades.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/hdf5_file.hpp"
#include "mpmrom/mpmrom_config.hpp"
#include "mpmrom/snapshot.hpp"

namespace mpmrom {

// Streams one run to disk: the constructor writes the header and the reference configuration, append() adds one
// output time, commit() finalises the file, writes the XDMF side file and renames both into place. If the writer is
// destroyed without commit() (an exception, a failed run), nothing appears under the final names. All arrays are on
// the host and row-major; every value must be finite, else the call throws std::runtime_error and writes nothing.
class SnapshotWriter {
 public:
  // X: (n, 3) reference positions in m, mass: (n) in kg, volume: (n) reference volumes in m^3 (both positive).
  SnapshotWriter(const std::string& path, const SnapshotHeader& header, std::size_t num_points, const real_t* X,
                 const real_t* mass, const real_t* volume);
  SnapshotWriter(const SnapshotWriter&) = delete;
  SnapshotWriter& operator=(const SnapshotWriter&) = delete;

  // time in s, strictly after the previous frame's; x: (n, 3) positions in m; v: (n, 3) velocities in m/s;
  // F: (n, 3, 3) deformation gradients; C: (n, 3, 3) affine velocity matrices (APIC) in 1/s.
  void append(double time, const real_t* x, const real_t* v, const real_t* F, const real_t* C);
  void commit();
  // For a run that failed: keeps the frames appended so far under failed_path_for(path) (and its XDMF), with the
  // reason in the root attribute "failure" and "complete" = 0, and returns that path. The path itself stays untouched.
  std::string commit_failed(const std::string& failure);

  std::size_t num_points() const { return num_points_; }
  std::size_t num_frames() const { return times_.size(); }

 private:
  enum class State { open, failed, committed };
  void require_open(const char* action) const;
  void finish(const std::string& h5_path, const std::string& failure);

  std::string path_;
  std::string scene_name_;
  std::size_t num_points_;
  std::vector<double> times_;
  State state_ = State::open;
  AtomicFile h5_;
  AtomicFile xdmf_;
  hdf5::File file_;
  hdf5::Dataset time_, x_, v_, F_, C_;
};

}  // namespace mpmrom
