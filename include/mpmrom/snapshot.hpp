// Snapshots of full-order runs (docs/snapshot_format.md): one HDF5 file per run holding the scene, the parameter
// values, the reference configuration and the state of every material point at each output time, with an XDMF side
// file next to it so that ParaView opens the run as a time series. Written in the build's precision, read back in
// double whatever precision wrote them.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

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

// Where a failed run's frames go: "runs/run_003.h5" -> "runs/run_003.failed.h5".
std::string failed_path_for(const std::string& snapshot_path);

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
  // Read at some of the run's material points only (read_snapshot's points): their indices in the run, in the order
  // held; X, mass, volume and the fields are those points'. Empty: every point.
  std::vector<std::size_t> point_ids;
};

// What read_snapshot loads: everything, or all but APIC's C (the 3/8 of a run that training and evaluation never use).
enum class SnapshotFields { All, WithoutAffine };

// Reads and validates everything: format tag and version, completeness, shapes consistent with the number of points
// and frames, finite values, positive masses and volumes, increasing times. Throws std::runtime_error with one line
// naming the file and the problem on any bad file. WithoutAffine checks C's shape but leaves Snapshot::C empty.
// points (indices into the run's material points, each below its count): only those points are kept, the fields
// read a frame at a time (the memory of one frame beyond what is kept); empty: every point.
Snapshot read_snapshot(const std::string& path, SnapshotFields fields = SnapshotFields::All,
                       const std::vector<std::size_t>& points = {});

// The reference configuration of a complete snapshot, every point's, with read_snapshot's checks of those arrays:
// what a model trained at some of the points keeps of all of them.
struct SnapshotReference {
  std::vector<double> X, mass, volume;  // (points, 3), (points), (points)
};
SnapshotReference read_snapshot_reference(const std::string& path);

// The header of a complete snapshot of this build's format (the same checks as read_snapshot, without the arrays):
// what a resumed sweep compares to tell a finished run from one of another scene.
SnapshotHeader read_snapshot_header(const std::string& path);

}  // namespace mpmrom
