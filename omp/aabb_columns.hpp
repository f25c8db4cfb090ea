// The broadphase's AABB test of one geom against a run of sorted geoms, over
// the grid's AABB columns (cell_grid.hpp): ODE's closed overlap test, two
// geoms per SSE2 compare where SSE2 is there, one at a time otherwise. Both
// write every candidate and advance past those that overlap (no branch on an
// outcome close to random in a pile); their compares are the same IEEE ones,
// so they pass the same pairs, NaN bounds included.
// Trade-off: the SSE2 loop reads one geom past the run (the columns carry
// CellGrid::kPad padding) and writes one candidate past its result, so the
// caller keeps room for one more candidate than the run holds.
#pragma once
#include <cstddef>
#include <cstdint>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "geom_info.hpp"
#include "lanes.hpp"

namespace parode::omp {

// Six bound columns in ODE's AABB order (min x, max x, min y, ...).
struct AabbColumns {
    const double* bound[6];
};

// Geom a against the geoms [b0, b1): candidates (a, b) at out[n], n advanced
// past the overlapping ones; returns the new n.
inline std::size_t overlap_span_scalar(const AabbColumns& c, std::size_t a, std::uint32_t b0, std::uint32_t b1,
                                       Candidate* out, std::size_t n) {
    double box[6];
    for (int i = 0; i < 6; ++i) box[i] = c.bound[i][a];
    const auto ua = static_cast<std::uint32_t>(a);
    for (std::uint32_t b = b0; b < b1; ++b) {
        double other[6];
        for (int i = 0; i < 6; ++i) other[i] = c.bound[i][b];
        out[n] = Candidate(ua, b);
        n += aabb_overlap(box, other);
    }
    return n;
}

#if defined(__SSE2__)
// The same, two geoms per compare (see the trade-off above).
inline std::size_t overlap_span_sse2(const AabbColumns& c, std::size_t a, std::uint32_t b0, std::uint32_t b1,
                                     Candidate* out, std::size_t n) {
    __m128d lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        lo[k] = _mm_set1_pd(c.bound[2 * k][a]);
        hi[k] = _mm_set1_pd(c.bound[2 * k + 1][a]);
    }
    const auto ua = static_cast<std::uint32_t>(a);
    for (std::uint32_t b = b0; b < b1; b += 2) {
        __m128d apart = _mm_setzero_pd();
        for (int k = 0; k < 3; ++k) {
            apart = _mm_or_pd(apart, _mm_cmpgt_pd(lo[k], _mm_loadu_pd(c.bound[2 * k + 1] + b)));
            apart = _mm_or_pd(apart, _mm_cmplt_pd(hi[k], _mm_loadu_pd(c.bound[2 * k] + b)));
        }
        const int keep = ~_mm_movemask_pd(apart) & (b + 1 < b1 ? 3 : 1);
        out[n] = Candidate(ua, b);
        n += keep & 1;
        out[n] = Candidate(ua, b + 1);
        n += keep >> 1;
    }
    return n;
}
#endif

inline std::size_t overlap_span(const AabbColumns& c, std::size_t a, std::uint32_t b0, std::uint32_t b1,
                                Candidate* out, std::size_t n) {
#if defined(__SSE2__)
    return overlap_span_sse2(c, a, b0, b1, out, n);
#else
    return overlap_span_scalar(c, a, b0, b1, out, n);
#endif
}

}  // namespace parode::omp
