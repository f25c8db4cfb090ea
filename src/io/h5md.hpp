// H5MD snapshots (h5md.nongnu.org, version 1.1) and their XDMF description.
// The file holds:
//   /h5md                 version [1, 1]; author (name), creator (parode, its version)
//   /parameters           scene, scene_file, dt, seed (attributes)
//   /particles/all        every body, in global-id order:
//     box                 dimension 3, boundary none x 3; edges and parode's
//                         own `origin`: the scene's extent at step 0
//     position, velocity  time-dependent: step [F], time [F], value [F][N][3]
//     orientation         parode's own (H5MD proposal 104): value [F][N][4],
//                         the quaternion (w, x, y, z)
//     x_axis              parode's own: value [F][N][3], the body x axis
//                         (single precision; for ParaView's Glyph filter);
//                         step and time are the same datasets in the four
//                         time-dependent elements (hard links)
//     id, species, mass, radius   fixed: [N] (species 0 catom, 1 sphere,
//                         2 box, 3 capsule, 4 cylinder; radius: the bounding
//                         sphere's)
//   /parode/statics       planes_points [4P][3], planes_cells [P][4],
//                         boxes_points [8B][3], boxes_cells [B][8]
// Every other number is a little-endian double or 64-bit integer. The processes
// write together: each its contiguous block of ids (domain/gather.hpp
// block_rows), through MPI-IO with independent transfers when distributed, so
// the file holds the one-process data whatever the number of processes.
// A frame's values and time are written before its step, and the file is
// flushed after each frame: a run killed at any moment leaves the frames
// counted by `step` complete (one process: SWMR mode, format 1.10, readable
// with h5py's swmr=True or after `h5clear -s`; several: format 1.8, see
// h5_file.hpp, whose values and time hold the space of every frame the run
// plans from the start, so a killed file's value and time datasets may be
// longer than `step`, and a completed one's are not); the XDMF beside it
// lists only frames already flushed.
// Strings (units, names) are variable-length UTF-8.
// Trade-off: one chunk per frame and block of 2^20 bodies, so a frame is
// written and read in large pieces; uncompressed, so that any reader (XDMF
// included) maps the datasets directly: 92 bytes per body per frame, 12 of
// them the x axis, which XDMF cannot compute from the quaternion (its JOIN
// concatenates arrays instead of interleaving them).
#pragma once
#include <memory>
#include <string>

#include "io/snapshot.hpp"

namespace parode {

// Collective; creates the file and its XDMF, writes nothing of the state yet.
// `frames`: how many the run will write (0: not known), the file space several
// processes take at once.
std::unique_ptr<SnapshotWriter> make_h5md_writer(const std::string& path, const Scene& scene, const World& world,
                                                 const Collectives& domain, std::size_t frames);
// The HDF5 library: "1.10.8 parallel" or "1.10.8 serial".
std::string h5md_library();

}  // namespace parode
