// Whether a scene can run on several processes, and why not: the rules the
// distributed domain enforces at start-up (mpi/mpi_domain.cpp), kept here in
// the serial core so that `parode info` gives the same verdict, word for word,
// in a build without MPI and without starting any process.
// Trade-off: a verdict (ok, kind, message) instead of a throw, so one caller
// can report it and the other turn it into the exception of its exit code.
#pragma once
#include <string>

#include "scene/scene.hpp"

namespace parode {

struct DistributionVerdict {
    bool ok = true;
    bool option_error = false;  // the --solver choice is the reason (exit 2), not the scene (exit 3)
    std::string reason;         // empty when ok
};

// The verdict for `scene` run with `solver` on `ranks` processes whose cells
// have edge `cell_edge` (the ghost halo reaches at most one cell).
DistributionVerdict distribution_verdict(const Scene& scene, const std::string& solver, int ranks, double cell_edge);

// How far from a body's centre its partners' centres can lie, the reach of
// the ghost halo: 2 r_max for a contact, 2 r_max + cutoff for a magnet, a
// program's range for a message. A rank holds a copy of every body within
// this distance of its cells, per axis (CellSpace::key with a reach).
double halo_reach(const Scene& scene);

// Why the migrate and exchange stages run on `ranks` processes.
std::string distributed_why(int ranks, double cell_edge);

}  // namespace parode
