// The build's pair search, scalar and AVX2 (see sphere_search.hpp). Both
// evaluate, per candidate, d2 = (dx*dx + dy*dy) + dz*dz and
// t = (ra + rb) + need, and keep the pair when d2 <= (t*t) * kFloatSlack:
// single IEEE operations in that order (no fused multiply-add in this
// library), so both keep the same pairs, in candidate order.
// Trade-off: the AVX2 path is chosen once at run time (the build targets
// baseline x86-64); other machines run the scalar loop.
#include "omp/grid/sphere_search.hpp"
#include "omp/grid/grid_pairs.hpp"
#include "util/scratch.hpp"

#include <array>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define PARODE_SEARCH_AVX2 1
#endif

namespace parode::omp {
namespace {

template <class T>
const T* col(const std::vector<Raw<T>>& v) {
    static_assert(sizeof(Raw<T>) == sizeof(T), "a column of plain values");
    return reinterpret_cast<const T*>(v.data());
}

std::uint32_t partners_scalar(const CellSpheres& c, std::size_t a, const Spans& sp, float need, Found& out) {
    ListEntry* o = out.room(sp.total());
    const float *x = col(c.x), *y = col(c.y), *z = col(c.z), *r = col(c.r);
    const std::uint32_t* walk = col(c.walk);
    const std::uint32_t wa = walk[a];
    std::uint32_t m = 0;
    for (int q = 0; q < 5; ++q) {
        for (std::uint32_t b = sp.begin[q]; b < sp.end[q]; ++b) {
            const float dx = x[a] - x[b], dy = y[a] - y[b], dz = z[a] - z[b];
            const float t = r[a] + r[b] + need;
            const bool near = dx * dx + dy * dy + dz * dz <= t * t * kFloatSlack;
            const std::uint32_t wb = walk[b];
            o[m].w = wb;
            m += near & (wb > wa);
            if (near & (wb < wa)) out.spilled.push_back(std::uint64_t{wb} << 32 | wa);
        }
    }
    out.kept += m;
    return m;
}

#ifdef PARODE_SEARCH_AVX2
// For each 8-bit mask, the lanes set in it, in order, then the others: a
// permute by this row packs the kept lanes to the front.
struct alignas(32) PackTable {
    std::array<std::array<std::int32_t, 8>, 256> rows;
    PackTable() {
        for (int mask = 0; mask < 256; ++mask) {
            int k = 0;
            for (int j = 0; j < 8; ++j) {
                if (mask >> j & 1) rows[mask][k++] = j;
            }
            for (int j = 0; j < 8; ++j) {
                if (!(mask >> j & 1)) rows[mask][k++] = j;
            }
        }
    }
};
const PackTable kPack;

bool avx2_available() {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("popcnt");
}
const bool kHasAvx2 = avx2_available();

// Eight candidates from b on (lanes from e on masked off); the kept walk
// positions packed at o + m. Returns the new m.
__attribute__((target("avx2,popcnt"), always_inline)) inline std::uint32_t span8(const CellSpheres& c, std::size_t a, std::uint32_t b,
                                                            std::uint32_t e, float need, ListEntry* o,
                                                            std::uint32_t m, Found& out) {
    const float *x = col(c.x), *y = col(c.y), *z = col(c.z), *r = col(c.r);
    const std::uint32_t* walk = col(c.walk);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const __m256i valid = _mm256_cmpgt_epi32(_mm256_set1_epi32(static_cast<int>(e - b)), lane);
    const __m256 dx = _mm256_sub_ps(_mm256_set1_ps(x[a]), _mm256_loadu_ps(x + b));
    const __m256 dy = _mm256_sub_ps(_mm256_set1_ps(y[a]), _mm256_loadu_ps(y + b));
    const __m256 dz = _mm256_sub_ps(_mm256_set1_ps(z[a]), _mm256_loadu_ps(z + b));
    const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
    const __m256 t = _mm256_add_ps(_mm256_add_ps(_mm256_set1_ps(r[a]), _mm256_loadu_ps(r + b)), _mm256_set1_ps(need));
    const __m256 reach = _mm256_mul_ps(_mm256_mul_ps(t, t), _mm256_set1_ps(kFloatSlack));
    const __m256i near = _mm256_and_si256(_mm256_castps_si256(_mm256_cmp_ps(d2, reach, _CMP_LE_OQ)), valid);
    const __m256i wb = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(walk + b));
    const __m256i wa = _mm256_set1_epi32(static_cast<int>(walk[a]));
    const int later = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_and_si256(near, _mm256_cmpgt_epi32(wb, wa))));
    int earlier = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_and_si256(near, _mm256_cmpgt_epi32(wa, wb))));
    const __m256i row = _mm256_load_si256(reinterpret_cast<const __m256i*>(kPack.rows[later].data()));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(o + m), _mm256_permutevar8x32_epi32(wb, row));
    for (; earlier; earlier &= earlier - 1) {
        out.spilled.push_back(std::uint64_t{walk[b + __builtin_ctz(earlier)]} << 32 | walk[a]);
    }
    return m + static_cast<std::uint32_t>(_mm_popcnt_u32(static_cast<unsigned>(later)));
}

// Each span in whole steps of eight (one at least, so that an empty span
// costs no mispredicted exit either), with room for a whole step.
__attribute__((target("avx2,popcnt"))) std::uint32_t partners_avx2(const CellSpheres& c, std::size_t a, const Spans& sp, float need, Found& out) {
    static_assert(sizeof(ListEntry) == 4, "walk positions packed as 32-bit lanes");
    std::uint32_t m = 0;
    for (int q = 0; q < 5; ++q) {
        std::uint32_t b = sp.begin[q];
        const std::uint32_t e = sp.end[q];
        ListEntry* o = out.room(m + (e - b) + CellSpheres::kPad);
        do {
            m = span8(c, a, b, e, need, o, m, out);
            b += 8;
        } while (b < e);
    }
    out.kept += m;
    return m;
}
#endif

}  // namespace

void CellSpheres::resize(std::size_t n) {
    for (auto* v : {&x, &y, &z, &r}) {
        scratch_resize(*v, n + kPad);
        for (std::size_t i = n; i < n + kPad; ++i) (*v)[i].v = 0;
    }
    scratch_resize(walk, n + kPad);
    for (std::size_t i = n; i < n + kPad; ++i) walk[i].v = 0;
    scratch_resize(key, n);
}

bool avx2_search() {
#ifdef PARODE_SEARCH_AVX2
    return kHasAvx2;
#else
    return false;
#endif
}

std::uint32_t partners(const CellGrid& g, const CellSpheres& c, std::size_t a, float need, Found& out,
                       [[maybe_unused]] bool simd) {
    const Spans sp = spans_of(g, a, c.key[a].v);
#ifdef PARODE_SEARCH_AVX2
    // Walk positions compared as signed 32-bit lanes.
    if (simd && kHasAvx2 && c.size() < (std::size_t{1} << 31)) return partners_avx2(c, a, sp, need, out);
#endif
    return partners_scalar(c, a, sp, need, out);
}

}  // namespace parode::omp
