// The broadphase's AABB test of one geom against a run of sorted grid geoms
// (cell_grid.hpp): ODE's closed overlap test on GridBox records, which hold an
// AABB with its maxima negated so that "apart on an axis" is one greater-than
// compare per pair of bounds, one SSE2 compare per axis where SSE2 is there,
// scalar compares otherwise. Both write every candidate and advance past those
// that overlap (no branch on an outcome close to random in a pile); negation
// is exact and the compares are the same IEEE ones as aabb_overlap's, so they
// pass the same pairs, NaN bounds included.
// Trade-off: one record (one cache line, tag included) per geom instead of six
// bound columns: the search over a half stencil's five spans reads five
// streams, not thirty, at the price of comparing one geom at a time.
#pragma once
#include <cstddef>
#include <cstdint>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "omp/grid/geom_info.hpp"
#include "omp/grid/lanes.hpp"

namespace parode::omp {

// What the pair filter needs of a geom besides its AABB.
struct GridTag {
    dBodyID body;
    std::uint32_t info;   // index into the GeomInfo table
    std::uint32_t flags;  // GeomFlag bits
};

// A sorted grid geom as the pair search reads it: its AABB as (min x, -max x,
// min y, -max y, min z, -max z), then its tag.
struct alignas(64) GridBox {
    double key[6];
    GridTag tag;
};

// The record of an AABB in ODE's order (min x, max x, min y, ...) and back.
inline void box_from_aabb(const dReal b[6], double key[6]) {
    for (int k = 0; k < 3; ++k) {
        key[2 * k] = b[2 * k];
        key[2 * k + 1] = -b[2 * k + 1];
    }
}
inline void aabb_from_box(const double key[6], dReal b[6]) {
    for (int k = 0; k < 3; ++k) {
        b[2 * k] = key[2 * k];
        b[2 * k + 1] = -key[2 * k + 1];
    }
}

// What a box's key is compared with: geom b is apart from geom a where some
// b.key[i] > probe(a)[i] (max x of a, -min x of a, ...).
inline void box_probe(const double key[6], double probe[6]) {
    for (int k = 0; k < 3; ++k) {
        probe[2 * k] = -key[2 * k + 1];
        probe[2 * k + 1] = -key[2 * k];
    }
}

// Geom a against the geoms [b0, b1): candidates (a, b) at out[n], n advanced
// past the overlapping ones; returns the new n.
inline std::size_t overlap_span_scalar(const GridBox* boxes, std::size_t a, std::uint32_t b0, std::uint32_t b1,
                                       Candidate* out, std::size_t n) {
    double probe[6];
    box_probe(boxes[a].key, probe);
    const auto ua = static_cast<std::uint32_t>(a);
    for (std::uint32_t b = b0; b < b1; ++b) {
        const double* k = boxes[b].key;
        const bool apart = (k[0] > probe[0]) | (k[1] > probe[1]) | (k[2] > probe[2]) | (k[3] > probe[3]) |
                           (k[4] > probe[4]) | (k[5] > probe[5]);
        out[n] = Candidate(ua, b);
        n += !apart;
    }
    return n;
}

#if defined(__SSE2__)
// The same, one axis per compare.
inline std::size_t overlap_span_sse2(const GridBox* boxes, std::size_t a, std::uint32_t b0, std::uint32_t b1,
                                     Candidate* out, std::size_t n) {
    double probe[6];
    box_probe(boxes[a].key, probe);
    const __m128d p0 = _mm_loadu_pd(probe), p1 = _mm_loadu_pd(probe + 2), p2 = _mm_loadu_pd(probe + 4);
    const auto ua = static_cast<std::uint32_t>(a);
    for (std::uint32_t b = b0; b < b1; ++b) {
        const double* k = boxes[b].key;
        __m128d apart = _mm_or_pd(_mm_cmpgt_pd(_mm_load_pd(k), p0), _mm_cmpgt_pd(_mm_load_pd(k + 2), p1));
        apart = _mm_or_pd(apart, _mm_cmpgt_pd(_mm_load_pd(k + 4), p2));
        out[n] = Candidate(ua, b);
        n += _mm_movemask_pd(apart) == 0;
    }
    return n;
}
#endif

inline std::size_t overlap_span(const GridBox* boxes, std::size_t a, std::uint32_t b0, std::uint32_t b1,
                                Candidate* out, std::size_t n) {
#if defined(__SSE2__)
    return overlap_span_sse2(boxes, a, b0, b1, out, n);
#else
    return overlap_span_scalar(boxes, a, b0, b1, out, n);
#endif
}

}  // namespace parode::omp
