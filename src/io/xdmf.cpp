// The XDMF description of an H5MD snapshot (see xdmf.hpp).
#include "io/xdmf.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "util/errors.hpp"

namespace parode {
namespace {

std::string num(double v) {
    std::ostringstream os;
    os.precision(17);
    os << v;
    return os.str();
}

// A dataset of the H5 file, of numbers of `bytes` bytes.
std::string heavy(const XdmfLayout& l, const std::string& dataset, const std::string& dims, const char* type,
                  const char* bytes = "8") {
    return "<DataItem Dimensions=\"" + dims + "\" NumberType=\"" + type + "\" Precision=\"" + bytes +
           "\" Format=\"HDF\">" + l.h5 + ":" + dataset + "</DataItem>";
}

// Frame f of a time series (frames x N x width), numbers of `bytes` bytes.
std::string slab(const XdmfLayout& l, const std::string& element, std::size_t f, int width, const char* bytes) {
    const std::string n = std::to_string(l.bodies), w = std::to_string(width);
    std::ostringstream os;
    os << "<DataItem ItemType=\"HyperSlab\" Dimensions=\"" << n << ' ' << w << "\" Type=\"HyperSlab\">"
       << "<DataItem Dimensions=\"3 3\" Format=\"XML\">" << f << " 0 0 1 1 1 1 " << n << ' ' << w << "</DataItem>"
       << heavy(l, std::string(kH5mdGroup) + "/" + element + "/value", std::to_string(std::max(l.held, l.steps.size())) + " " + n + " " + w,
                "Float", bytes)
       << "</DataItem>";
    return os.str();
}

// Frame f of a scalar time series (frames x N).
std::string slab2(const XdmfLayout& l, const std::string& element, std::size_t f) {
    const std::string n = std::to_string(l.bodies);
    std::ostringstream os;
    os << "<DataItem ItemType=\"HyperSlab\" Dimensions=\"" << n << "\" Type=\"HyperSlab\">"
       << "<DataItem Dimensions=\"3 2\" Format=\"XML\">" << f << " 0 1 1 1 " << n << "</DataItem>"
       << heavy(l, std::string(kH5mdGroup) + "/" + element + "/value", std::to_string(std::max(l.held, l.steps.size())) + " " + n, "Float",
                "8")
       << "</DataItem>";
    return os.str();
}

std::string attribute(const std::string& name, const char* type, const std::string& item) {
    return "      <Attribute Name=\"" + name + "\" AttributeType=\"" + type + "\" Center=\"Node\">" + item + "</Attribute>\n";
}

std::string fixed(const XdmfLayout& l, const std::string& name, const char* type) {
    return attribute(name, "Scalar", heavy(l, std::string(kH5mdGroup) + "/" + name, std::to_string(l.bodies), type));
}

void frame(std::ostream& os, const XdmfLayout& l, std::size_t f) {
    os << "    <Grid Name=\"step " << l.steps[f] << "\" GridType=\"Uniform\">\n"
       << "      <Time Value=\"" << num(l.times[f]) << "\"/>\n"
       << "      <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << l.bodies << "\" NodesPerElement=\"1\"/>\n"
       << "      <Geometry GeometryType=\"XYZ\">" << slab(l, "position", f, 3, "8") << "</Geometry>\n"
       << attribute("velocity", "Vector", slab(l, "velocity", f, 3, "8"))
       << attribute("orientation", "Matrix", slab(l, "orientation", f, 4, "8"))
       << attribute("x_axis", "Vector", slab(l, "x_axis", f, 3, "4")) << fixed(l, "radius", "Float")
       << fixed(l, "mass", "Float") << fixed(l, "id", "Int") << fixed(l, "species", "Int");
    for (const std::string& v : l.values) os << attribute("program_" + v, "Scalar", slab2(l, "program_" + v, f));
    os << "    </Grid>\n";
}

void cells(std::ostream& os, const XdmfLayout& l, const char* name, const char* topology, std::size_t count, int corners) {
    if (count == 0) return;
    const std::string at = std::string(kStaticsGroup) + "/" + name, c = std::to_string(count);
    const std::string points = std::to_string(count * static_cast<std::size_t>(corners));
    os << "    <Grid Name=\"" << name << "\" GridType=\"Uniform\">\n"
       << "      <Topology TopologyType=\"" << topology << "\" NumberOfElements=\"" << c << "\">"
       << heavy(l, at + "_cells", c + " " + std::to_string(corners), "Int") << "</Topology>\n"
       << "      <Geometry GeometryType=\"XYZ\">" << heavy(l, at + "_points", points + " 3", "Float") << "</Geometry>\n"
       << "    </Grid>\n";
}

}  // namespace

std::string xdmf_text(const XdmfLayout& l) {
    std::ostringstream os;
    os << "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
       << "<Xdmf Version=\"2.0\">\n  <Domain>\n"
       << "    <Grid Name=\"bodies\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    for (std::size_t f = 0; f < l.steps.size(); ++f) frame(os, l, f);
    os << "    </Grid>\n";
    if (l.quads + l.hexes > 0) {
        os << "    <Grid Name=\"statics\" GridType=\"Collection\" CollectionType=\"Spatial\">\n";
        cells(os, l, "planes", "Quadrilateral", l.quads, 4);
        cells(os, l, "boxes", "Hexahedron", l.hexes, 8);
        os << "    </Grid>\n";
    }
    os << "  </Domain>\n</Xdmf>\n";
    return os.str();
}

// Written beside it and renamed over it: a reader sees the old or the new one whole.
void write_xdmf(const std::string& path, const XdmfLayout& layout) {
    const std::string tmp = path + ".tmp";
    {
        std::ofstream out(tmp, std::ios::trunc);
        if (!out) throw OutputError(tmp + ": cannot open the XDMF file for writing");
        out << xdmf_text(layout);
        out.flush();
        if (!out) throw OutputError(tmp + ": the XDMF file could not be written (disk full?)");
    }
    std::error_code e;
    std::filesystem::rename(tmp, path, e);
    if (e) throw OutputError(path + ": cannot rename " + tmp + " into place (" + e.message() + ")");
}

std::string xdmf_path(const std::string& h5_path) {
    return std::filesystem::path(h5_path).replace_extension(".xdmf").string();
}

}  // namespace parode
