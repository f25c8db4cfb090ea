// The pair search of the grid backend, one chunk of sorted geoms at a time:
// broadphase, then narrowphase. The broadphase tests each geom's AABB against
// the later geoms of its cell, the half stencil of forward cells and the big
// list, reading the grid's one-line records (grid_boxes.hpp: ODE's closed
// overlap test, an SSE2 compare per axis, scalar where SSE2 is absent), writing every
// candidate and advancing past it only if it passes: no branch on an outcome
// that is close to random in a pile. The narrowphase runs over the survivors
// (about a quarter): the rest of ODE's collideAABBs filter (same body,
// category and collide bits), then sphere-sphere and sphere-plane pairs
// through the exact contact test (the contact itself is computed by the
// merge, lanes.hpp), other primitive pairs through dCollide, the rest set
// aside for the serial pass.
// Trade-off: a candidate buffer per thread (8 bytes a candidate, a chunk's
// worth) in exchange for two tight loops that each time their own share; the
// big list is tested whole in the broadphase (it is short and scalar anyway).
#pragma once
#include <cstddef>

#include "cell_grid.hpp"
#include "geom_info.hpp"
#include "lanes.hpp"

namespace parode::omp {

struct PairInputs {
    const CellGrid* grid = nullptr;
    const GridEntry* big = nullptr;       // big list: entries and their prims
    const PrimData* big_prims = nullptr;
    std::size_t nbig = 0;
    GeomView infos;                       // for bits beyond the entries' flags
    int max_contacts = 1;
};

// Pairs of the sorted grid geoms [a0, a1) with later grid geoms and with the
// big list, into `lane`, timing its broadphase and narrowphase.
void chunk_pairs(const PairInputs& in, std::size_t a0, std::size_t a1, Lane& lane);
// Pairs among the big geoms, into `lane` (stored runs).
void big_pairs(const PairInputs& in, Lane& lane);

}  // namespace parode::omp
