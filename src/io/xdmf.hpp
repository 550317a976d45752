// XDMF 3 side files for ParaView: a temporal collection of point clouds stored in an HDF5 file, named relative to the
// side file so that the pair can be moved together. ParaView's Xdmf3 readers cannot read HyperSlab DataItems (they
// size and type an array before reading it), so every frame's arrays are plain datasets (virtual ones, views of the
// stored arrays: Group::create_entry_view), and /xdmf/vertices gives the readers the one-vertex cells they need to
// draw the points.
#pragma once

#include <string>
#include <vector>

#include "io/hdf5_file.hpp"

namespace mpmrom::impl {

// A point array: per frame at "<path>/<frame>" (per_frame) or the same dataset at every frame.
struct XdmfArray {
  std::string name;
  int components = 1;  // 1: scalar, 3: vector, 9: 3x3 tensor
  int bytes = 8;       // 4 or 8
  std::string path;
  bool per_frame = true;
};

// One point cloud: its positions per frame at "<geometry>/<frame>" and its arrays.
struct XdmfBlock {
  std::string name;
  std::string geometry;
  int geometry_bytes = 8;
  std::vector<XdmfArray> arrays;
};

// The side file's text. One block: each frame is that block's point cloud; several (a batch of rollouts): each frame
// is a spatial collection of them, which ParaView shows as a multiblock data set.
std::string xdmf_text(const std::string& h5_name, const std::string& title, std::size_t num_points,
                      const std::vector<double>& times, const std::vector<XdmfBlock>& blocks);

// /xdmf/vertices (0 .. num_points - 1), which xdmf_text's topology refers to.
void write_xdmf_vertices(hdf5::Group& xdmf, std::size_t num_points);

std::string xml_escaped(const std::string& text);

}  // namespace mpmrom::impl
