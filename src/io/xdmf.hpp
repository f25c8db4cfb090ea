// The XDMF file beside an H5MD snapshot (FILE.xdmf next to FILE.h5), so that
// ParaView (and VisIt) open the bodies as points: a temporal collection of one
// grid per frame whose geometry and attributes are HyperSlab items into the
// H5 datasets (position; velocity, orientation as a quaternion w, x, y, z, the
// body x axis, radius, mass, id, species), and the static geometry in a grid
// block of its own (planes as quadrilaterals, static geoms as hexahedra).
// Trade-off: XDMF 2, plain XML written directly (ParaView's "XDMF Reader"
// reads it; no XDMF library to build against); a description only, so the
// whole file is rewritten (atomically: beside it, then renamed) as frames
// reach the disk and at the end, one grid per frame.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace parode {

struct XdmfLayout {
    std::string h5;  // the H5 file's name, relative to the XDMF file
    std::uint64_t bodies = 0;
    std::vector<long> steps;     // one grid per frame
    std::vector<double> times;
    std::size_t held = 0;  // frames the value datasets hold, when more than steps.size()
    std::size_t quads = 0, hexes = 0;  // static cells (0: no grid)
    std::vector<std::string> values;   // the catom program's values: program_<name>, [F][N]
};

constexpr const char* kH5mdGroup = "/particles/all";
constexpr const char* kStaticsGroup = "/parode/statics";

std::string xdmf_text(const XdmfLayout& layout);
// Throws OutputError naming the file.
void write_xdmf(const std::string& path, const XdmfLayout& layout);
// FILE.h5 -> FILE.xdmf (any extension replaced).
std::string xdmf_path(const std::string& h5_path);

}  // namespace parode
