// Per-thread output of the narrowphase ("lanes") and their merge into canonical
// contact order. Each task appends to the lane of the thread running it; a pair's
// contacts are one contiguous run, recorded as (lo id, hi id, where, how many).
// The merge orders runs by (lo, hi) with a parallel bucket sort on the lower id
// and copies them out, so the result is independent of which thread collided
// which pair.
// Trade-off: a run table beside the contacts (16 bytes per touching pair) avoids
// sorting the 112-byte contact records themselves.
#pragma once
#include <ode/ode.h>

#include <cstdint>
#include <vector>

#include "collide/contacts.hpp"
#include "fast_pairs.hpp"

namespace parode::omp {

struct PairRun {
    std::uint32_t lo, hi, begin, count;
};

// A pair that must run serially (unsafe class or nested space), in the order
// ODE's near-callback would receive it.
struct DeferredPair {
    dGeomID a, b;
};

struct alignas(64) Lane {
    ContactBuffer buf;
    std::vector<PairRun> runs;
    std::vector<DeferredPair> deferred;

    void clear() {
        buf.clear();
        runs.clear();
        deferred.clear();
    }
    // Sphere/sphere or sphere/plane pair through the exact fast path.
    void fast(const PrimData& a, bool a_sphere, const PrimData& b, bool b_sphere, int max_contacts);
    // Any pair through dCollide in canonical argument order.
    void generic(dGeomID a, dGeomID b, int max_contacts);
};

struct RunRef {
    std::uint32_t lo, hi, lane, begin, count;
};

// Work arrays of the merge, kept between calls so no call allocates afresh.
struct MergeScratch {
    std::vector<RunRef> refs;
    std::vector<std::size_t> next, block_start, contacts;
};

// All lanes' contacts in canonical order, into `out` (overwritten). Call inside
// a parallel region (copies run as tasks) or outside it (serially).
void merge_lanes(std::vector<Lane>& lanes, ContactBuffer& out, MergeScratch& scratch);

}  // namespace parode::omp
