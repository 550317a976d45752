#include "io/xdmf.hpp"

#include <cstdint>
#include <numeric>
#include <sstream>

#include "io/file_checks.hpp"

namespace mpmrom::impl {

std::string xml_escaped(const std::string& text) {
  std::string escaped;
  for (const char c : text) {
    switch (c) {
      case '&': escaped += "&amp;"; break;
      case '<': escaped += "&lt;"; break;
      case '>': escaped += "&gt;"; break;
      case '"': escaped += "&quot;"; break;
      default: escaped += c;
    }
  }
  return escaped;
}

std::string xdmf_text(const std::string& h5_name, const std::string& title, std::size_t num_points,
                      const std::vector<double>& times, const std::vector<XdmfBlock>& blocks) {
  const std::string n = std::to_string(num_points), file = xml_escaped(h5_name);
  const auto item = [&](const std::string& dimensions, const std::string& type, const std::string& dataset) {
    return "<DataItem Dimensions=\"" + dimensions + "\" " + type + " Format=\"HDF\">" + file + ":" +
           xml_escaped(dataset) + "</DataItem>";
  };
  const auto real = [](int bytes) { return "NumberType=\"Float\" Precision=\"" + std::to_string(bytes) + "\""; };
  const bool several = blocks.size() > 1;
  std::ostringstream out;
  out << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n"
      << "    <Grid Name=\"" << xml_escaped(title) << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (std::size_t frame = 0; frame < times.size(); ++frame) {
    const std::string k = std::to_string(frame), time = number_string(times[frame], 17);
    const std::string indent = several ? "        " : "      ";
    if (several) {
      out << "      <Grid Name=\"frame " << frame << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
          << "        <Time Value=\"" << time << "\"/>\n";
    }
    for (const XdmfBlock& block : blocks) {
      out << indent << "<Grid Name=\"" << (several ? xml_escaped(block.name) : "frame " + k)
          << "\" GridType=\"Uniform\">\n";
      if (!several) out << indent << "  <Time Value=\"" << time << "\"/>\n";
      out << indent << "  <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n << "\" NodesPerElement=\"1\">"
          << item(n, "NumberType=\"Int\" Precision=\"8\"", "/xdmf/vertices") << "</Topology>\n"
          << indent << "  <Geometry GeometryType=\"XYZ\">"
          << item(n + " 3", real(block.geometry_bytes), block.geometry + "/" + k) << "</Geometry>\n";
      for (const XdmfArray& array : block.arrays) {
        const char* type = array.components == 1 ? "Scalar" : array.components == 3 ? "Vector" : "Tensor";
        const std::string dims = array.components == 1 ? n : array.components == 3 ? n + " 3" : n + " 3 3";
        out << indent << "  <Attribute Name=\"" << xml_escaped(array.name) << "\" AttributeType=\"" << type
            << "\" Center=\"Node\">"
            << item(dims, real(array.bytes), array.per_frame ? array.path + "/" + k : array.path) << "</Attribute>\n";
      }
      out << indent << "</Grid>\n";
    }
    if (several) out << "      </Grid>\n";
  }
  out << "    </Grid>\n  </Domain>\n</Xdmf>\n";
  return out.str();
}

void write_xdmf_vertices(hdf5::Group& xdmf, std::size_t num_points) {
  std::vector<std::int64_t> vertices(num_points);
  std::iota(vertices.begin(), vertices.end(), std::int64_t(0));
  xdmf.create_dataset("vertices", hdf5::Element::int64, {num_points}).write(vertices.data());
}

}  // namespace mpmrom::impl
