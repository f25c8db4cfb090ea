// Snapshots: the state of every body at step 0 and every K steps, written in
// the pipeline's `output` stage. The file name decides the format: FILE.h5 or
// FILE.hdf5 is H5MD (h5md.hpp) with its XDMF description FILE.xdmf beside it,
// for ParaView; any other name is CSV (step, body, x, y, z, qw, qx, qy, qz).
// Every body in global-id order at full double precision, whatever the
// number of processes.
// Trade-off: CSV goes through the root (simple, fine for small scenes and a
// spreadsheet); H5MD is written by every process together, each its block of
// ids, and is the one for large runs.
#pragma once
#include <memory>
#include <string>

#include "domain/collectives.hpp"
#include "scene/scene.hpp"
#include "world/world.hpp"

namespace parode {

class SnapshotWriter {
public:
    virtual ~SnapshotWriter() = default;
    // Collective: the state of every body now.
    virtual void write(const World& world, long step, double time) = 0;
    // Collective: completes the files. Destruction does it too, ignoring errors.
    virtual void close() {}
};

bool is_h5md_path(const std::string& path);
// "1.10.8 parallel" or "1.10.8 serial"; empty in a build without HDF5.
std::string hdf5_version();
// Opens the snapshot files and writes the current state as the first frame
// (collective). `frames`: how many the run will write, this one included (0:
// not known). Throws OutputError when a file cannot be written, and
// std::invalid_argument for an H5MD name in a build without HDF5.
std::unique_ptr<SnapshotWriter> make_snapshot_writer(const std::string& path, const Scene& scene, const World& world,
                                                     const Collectives& domain, long step, double time,
                                                     std::size_t frames);

}  // namespace parode
