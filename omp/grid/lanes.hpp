// Per-thread output of the narrowphase ("lanes") and their merge into canonical
// contact order. Each task appends to the lane of the thread running it; a
// pair's contacts are one run, recorded as (lo id, hi id, where). A run of the
// grid's sphere-sphere and sphere-plane pairs stores no contact: it names the
// two geoms' compact copies, and the merge computes the contact (the same
// function, the same inputs, so the same bits) straight into its place in the
// output. Other runs store their contacts in the lane's buffer and are copied.
// The merge orders runs by (lo, hi) with a parallel bucket sort on the lower
// id, so the result is independent of which thread collided which pair.
// Trade-off: a sphere contact is computed twice (a few dozen flops) so that it
// is written once, where the merge puts it, instead of twice (64 bytes each)
// through a buffer: half the memory and half the traffic of the stage.
#pragma once
#include <ode/ode.h>

#include <cstdint>
#include <vector>

#include "collide/contacts.hpp"
#include "omp/grid/fast_pairs.hpp"
#include "omp/grid/geom_info.hpp"

namespace parode::omp {

constexpr std::uint32_t kStored = 1u << 31;  // PairRun::a: contacts stored in the lane
constexpr std::uint32_t kBigList = 1u << 31;  // PairRun::b: a geom of the big list

// a & kStored: b contacts at buf[a & ~kStored] of the lane. Otherwise one
// contact of the geoms at entries a and b of the geom table (b & kBigList:
// entry b & ~kBigList of the big list), to be computed by the merge. Table
// entries, not grid positions: the table follows the space's geom order,
// which in World's spaces is id order, the order the merge writes in.
struct PairRun {
    PairRun() {}  // left uninitialised: buffers are sized first, then filled
    PairRun(std::uint32_t lo_, std::uint32_t hi_, std::uint32_t a_, std::uint32_t b_) : lo(lo_), hi(hi_), a(a_), b(b_) {}
    std::uint32_t lo, hi, a, b;
};

// A pair that must run serially (unsafe class or nested space), in the order
// ODE's near-callback would receive it.
struct DeferredPair {
    dGeomID a, b;
};

// Two grid positions whose AABBs overlap (b as in PairRun).
struct Candidate {
    Candidate() {}  // left uninitialised: buffers are sized first, then filled
    Candidate(std::uint32_t a_, std::uint32_t b_) : a(a_), b(b_) {}
    std::uint32_t a, b;
};

struct alignas(64) Lane {
    ContactBuffer buf;
    std::vector<PairRun> runs;
    std::vector<DeferredPair> deferred;
    std::vector<Candidate> candidates, others;  // scratch of the pair search
    double broad = 0, narrow = 0;       // seconds of this call in each

    void clear() {
        buf.clear();
        runs.clear();
        deferred.clear();
        broad = narrow = 0;
    }
    // Sphere/sphere or sphere/plane pair through the exact fast path, stored.
    void fast(const PrimData& a, bool a_sphere, const PrimData& b, bool b_sphere, int max_contacts);
    // Any pair through dCollide in canonical argument order, stored.
    void generic(dGeomID a, dGeomID b, int max_contacts);
};

// Where the merge finds the geoms of unstored runs.
struct FastSource {
    const GeomInfo* table = nullptr;
    const PrimData* big = nullptr;
    int max_contacts = 1;
    const PrimData& prim(std::uint32_t b) const { return b & kBigList ? big[b & ~kBigList] : table[b].prim; }
};

// Turns the lane's unstored runs into stored ones (before the geom table they
// name is read again for another space).
void store_fast_runs(Lane& lane, const FastSource& fast);

struct RunRef {
    RunRef() {}  // left uninitialised: buffers are sized first, then filled
    RunRef(std::uint32_t lo_, std::uint32_t hi_, std::uint32_t lane_, std::uint32_t a_, std::uint32_t b_)
        : lo(lo_), hi(hi_), lane(lane_), a(a_), b(b_) {}
    std::uint32_t lo, hi, lane, a, b;
};

// A thread's arrays for sorting one block of runs (lanes.cpp, sort_block).
struct BlockSort {
    std::vector<std::uint32_t> start, next;
    std::vector<RunRef> sorted;
};

// Work arrays of the merge, kept between calls so no call allocates afresh.
struct MergeScratch {
    std::vector<RunRef> refs;
    std::vector<std::size_t> next, block_start, block_contacts, contacts;
    std::vector<unsigned char> repeated;
    std::vector<BlockSort> per_thread;  // by thread number in the merge's team
};

// All lanes' contacts in canonical order, into `out` (overwritten). Call inside
// a parallel region (copies run as tasks) or outside it (serially). Returns
// whether the lanes held their runs in canonical order already (no sort).
bool merge_lanes(std::vector<Lane>& lanes, const FastSource& fast, ContactBuffer& out, MergeScratch& scratch);

}  // namespace parode::omp
