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

#include "omp/grid/cell_grid.hpp"
#include "omp/grid/geom_info.hpp"
#include "omp/grid/lanes.hpp"

namespace parode::omp {

struct PairInputs {
    const CellGrid* grid = nullptr;
    const GridEntry* big = nullptr;       // big list: entries and their prims
    const PrimData* big_prims = nullptr;
    std::size_t nbig = 0;
    GeomView infos;                       // for bits beyond the entries' flags
    int max_contacts = 1;
};

// ODE's collideAABBs filter beyond the AABB test: same body, category and
// collide bits (from the flags, or from infos when they do not fit there).
inline bool tags_pass(const PairInputs& in, const GridTag& a, const GridTag& b) {
    const bool bits = ((a.flags | b.flags) & kWideBits) ? body_and_bits_pass(in.infos.full(a.info), in.infos.full(b.info))
                                                        : packed_bits_pass(a.flags, b.flags);
    return !(a.body && a.body == b.body) & bits;
}

// The complete filter on two entries.
inline bool passes(const PairInputs& in, const GridEntry& a, const GridEntry& b) {
    return aabb_overlap(a.aabb, b.aabb) & tags_pass(in, a.tag, b.tag);
}

// The spans of sorted positions geom a is tested against: the later geoms of
// its cell and the next, then the four forward rows of the half stencil.
struct Spans {
    std::uint32_t begin[5], end[5];
    std::size_t total() const {
        std::size_t m = 0;
        for (int r = 0; r < 5; ++r) m += end[r] - begin[r];
        return m;
    }
};

// The same for sorted position a in the cell of key k (after CellGrid::sort,
// which keeps no keys by position).
inline Spans spans_of(const CellGrid& g, std::size_t a, std::uint64_t k) {
    Spans s;
    std::uint32_t b0 = 0;
    g.range(k, k + 1, b0, s.end[0]);
    s.begin[0] = static_cast<std::uint32_t>(a) + 1;
    for (int r = 0; r < 4; ++r) {
        const std::uint64_t c = k + g.row_offsets()[r];
        g.range(c - 1, c + 1, s.begin[r + 1], s.end[r + 1]);
    }
    return s;
}

inline Spans spans_of(const CellGrid& g, std::size_t a) { return spans_of(g, a, g.key(a)); }

// Pairs of the sorted grid geoms [a0, a1) with later grid geoms and with the
// big list, into `lane`, timing its broadphase and narrowphase.
void chunk_pairs(const PairInputs& in, std::size_t a0, std::size_t a1, Lane& lane);
// Pairs among the big geoms, into `lane` (stored runs).
void big_pairs(const PairInputs& in, Lane& lane);

}  // namespace parode::omp
