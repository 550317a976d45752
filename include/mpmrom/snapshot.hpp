// Snapshots of full-order runs (docs/snapshot_format.md): one HDF5 file per run holding the scene, the parameter
// values, the reference configuration and the state of every material point at each output time, with an XDMF side
// file next to it so that ParaView opens the run as a time series. Written in the build's precision, read back in
// double whatever precision wrote them.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/hdf5_file.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom {

inline constexpr const char* snapshot_format = "mpmrom-snapshot";
inline constexpr int snapshot_format_version = 2;  // 2: fixed-length string attributes (1: variable-length)

struct SnapshotHeader {
  std::string scene_name;
  std::string scene_text;                                  // the full scene file text, stored verbatim
  std::vector<std::pair<std::string, double>> parameters;  // the run's parameter values (name, value), in order
  double dx = 0;                                           // grid spacing of the run, m
};

// The XDMF side file of a snapshot: the same path with the extension .xmf ("out/run.h5" -> "out/run.xmf").
std::string xdmf_path_for(const std::string& snapshot_path);

// Streams one run to disk: the constructor writes the header and the reference configuration, append() adds one
// output time, commit() finalises the file, writes the XDMF side file and renames both into place. If the writer is
// destroyed without commit() (an exception, a failed run), nothing appears under the final names. All arrays are on
// the host and row-major; every value must be finite, else the call throws std::runtime_error and writes nothing.
// Where a failed run's frames go: "runs/run_003.h5" -> "runs/run_003.failed.h5".
std::string failed_path_for(const std::string& snapshot_path);

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

// A whole run read back, in double whatever precision it was written in.
struct Snapshot {
  SnapshotHeader header;
  std::string precision;       // "float" or "double": the precision of the build that wrote it
  std::string mpmrom_version;  // of the build that wrote it
  std::string git_commit;      // of the build that wrote it
  std::size_t num_points = 0;
  std::size_t num_frames = 0;
  std::vector<double> X, mass, volume;  // (points, 3), (points), (points)
  std::vector<double> time;             // (frames)
  std::vector<double> x, v, F, C;       // (frames, points, 3), (frames, points, 3), (frames, points, 3, 3) twice
};

// What read_snapshot loads: everything, or all but APIC's C (the 3/8 of a run that training and evaluation never use).
enum class SnapshotFields { All, WithoutAffine };

// Reads and validates everything: format tag and version, completeness, shapes consistent with the number of points
// and frames, finite values, positive masses and volumes, increasing times. Throws std::runtime_error with one line
// naming the file and the problem on any bad file. WithoutAffine checks C's shape but leaves Snapshot::C empty.
Snapshot read_snapshot(const std::string& path, SnapshotFields fields = SnapshotFields::All);

// The header of a complete snapshot of this build's format (the same checks as read_snapshot, without the arrays):
// what a resumed sweep compares to tell a finished run from one of another scene.
SnapshotHeader read_snapshot_header(const std::string& path);

}  // namespace mpmrom
