// The rows of one contact as the contact solver relaxes them, in two forms.
// SphereRow, for sphere-sphere and sphere-plane contacts between bodies of
// isotropic inertia: the contact point lies on the line of the centres, so the
// normal row has no angular part and each friction row's angular part is the
// lever length times (tangent x normal) = -t2 for t1 and t1 for t2. The row
// keeps the normal (the tangents follow from it, tangent_frame), the two
// lever lengths, friction coefficient, right-hand sides and impulses, and
// what the relaxation would otherwise recompute each time from these and the
// bodies' rows (inverse mass and inverse inertia, beside the velocity
// corrections in one BodyRow): the effective masses (SOR factor over
// J inv(M) J^T + CFM: one for the normal row, one for both friction rows,
// whose J inv(M) J^T are equal for unit tangents) and the tangent frame's
// scale (one over a root). 128 bytes, two cache lines of the rows' 64-byte
// aligned array, against 650 for the general Block, which keeps J and
// inv(M) J^T as 3 x 12 doubles for any other contact. The build computes
// them with the relaxation's own operations (effective_masses,
// tangent_scale), so keeping them changed no bit.
// Trade-off: two code paths for one contact model; 24 bytes more a contact
// than recomputing them at every relaxation (a square root and three
// divisions a contact: with the four-lane block loads the sweeps are bound by
// their instructions, and these cost a fifth of them, docs/performance/million-catoms.md);
// the sphere path drops the rounding-level angular terms the general Jacobian
// carries, so the two agree to rounding, not bit for bit (test_contact_rows
// holds them together).
#pragma once
#include <ode/ode.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace parode {

// Velocity corrections inv(M) J^T lambda of one body (linear, angular), its
// inverse mass and scalar inverse inertia (0 when its inertia is not
// isotropic): all the sweeps read of a body.
struct alignas(64) BodyRow {
    double fc[6];
    double invm;
    double invi;
};

struct SphereRow {
    double n[3];          // into body 1
    double r1, r2;        // lever lengths: contact point = x1 - r1 n = x2 + r2 n; r2 = 0 when static
    double rhs[3];        // target velocity terms, unscaled
    double lambda[3];
    double mu;            // friction rows clamped to +-mu lambda[0] (to 0 when mu = 0)
    double ad_n, ad_t;    // effective masses of the normal and the friction rows
    double kt;            // the tangent frame's scale (tangent_scale of n)
    std::int32_t b1, b2;  // body slots; b2 < 0: static
};
static_assert(sizeof(SphereRow) == 128, "a sphere row is 15 doubles and two slots: two cache lines");
// Four (AVX) or eight (AVX-512) lanes read a row as four blocks of four (n, r1 |
// r2, rhs | lambda, mu | ad_n, ad_t, kt, slots) and write lambda and mu back
// as one block.
static_assert(offsetof(SphereRow, n) == 0 && offsetof(SphereRow, r1) == 24 && offsetof(SphereRow, r2) == 32 &&
                  offsetof(SphereRow, rhs) == 40 && offsetof(SphereRow, lambda) == 64 && offsetof(SphereRow, mu) == 88 &&
                  offsetof(SphereRow, ad_n) == 96 && offsetof(SphereRow, ad_t) == 104 && offsetof(SphereRow, kt) == 112,
              "a sphere row's doubles lie in the order the four-lane loads read them");

// What the sweeps fetch early, for a stream of rows at position p of n: the
// body rows of its contact kBodyAhead places on, its row's two lines
// kRowAhead places on (none past the last). Forced inline: as a function of
// its own GCC finds it free of effects and drops the call.
inline constexpr std::size_t kBodyAhead = 4, kRowAhead = 16;
__attribute__((always_inline)) inline void prefetch_ahead(const SphereRow* rows, std::size_t n, const BodyRow* hot,
                                                          std::size_t p) {
    if (p + kBodyAhead < n) {
        const SphereRow& A = rows[p + kBodyAhead];
        if (A.b1 >= 0) __builtin_prefetch(&hot[A.b1], 1);
        if (A.b2 >= 0) __builtin_prefetch(&hot[A.b2], 1);
    }
    if (p + kRowAhead < n) {
        const char* row = reinterpret_cast<const char*>(&rows[p + kRowAhead]);
        for (std::size_t b = 0; b < sizeof(SphereRow); b += 64) __builtin_prefetch(row + b, 1);  // two whole lines
    }
}

// What every sphere row of a step shares: the SOR factor and CFM / dt (the
// solver keeps a contact as a SphereRow only where all its rows' CFM is the
// solver's, ContactSolver::sphere_pair).
struct SphereRowConstants {
    double sor_w;
    double cfm;  // cfm / dt
};

struct Block {
    std::int32_t b1 = -1, b2 = -1;  // body slots; b2 < 0: static
    int rows = 1;
    double mu = 0;
    double J[3][12];    // scaled by Ad
    double iMJ[3][12];  // inv(M) J^T, unscaled
    double rhs[3], cfm[3], lambda[3];
    double n[3], ad[3];  // the normal (into body 1), each row's Ad (substeps recompute the normal row's rhs)
};

// A contact as the builder sees it: bodies, normal into body 1 (ODE's
// convention), lever arms from the body centres to the contact point, depth.
struct ContactFrame {
    std::int32_t b1, b2;   // body slots; b2 < 0: static
    double n[3], c1[3], c2[3];
    double depth;
};

// What a row's build needs beside the frame: per body (1, 2) the velocity
// terms tmp = v / dt + inv(M) f_ext and the actual velocity (bounce), the
// surface, and the solver's settings.
struct RowInputs {
    const double* tmp[2];  // 6 each; tmp[1] null when static; zeros with substeps (their velocity form)
    const double* vel[2];
    const double* invI[2];  // world-frame inverse inertia (Block only)
    double invm[2], invi[2];  // inverse mass, scalar inverse inertia (0: see invI)
    const dSurfaceParameters* surface;
    double fps, erp, cfm, surface_layer, max_correcting_vel, sor_w;
    int substeps;          // > 1: fps is a substep's, ERP and CFM converted (substep_softness)
    struct Kept* kept;     // null, or where the build keeps what substeps recompute the normal target from
};

// What a row's substeps recompute its targets from: the depth at the step's
// start, the contact's ERP at the substep, and the bounce target (0: none).
struct Kept {
    double depth, erp, bounce;
};

// The ERP and CFM at a substep dt / S of a contact whose ERP and CFM are
// given at dt: the same spring and damper (ODE's ERP = h kp / (h kp + kd),
// CFM = 1 / (h kp + kd)); a rigid contact (CFM 0) keeps the share of its depth
// corrected over the whole step.
inline void substep_softness(double erp, double cfm, int substeps, double& erp_s, double& cfm_s) {
    if (substeps <= 1) {
        erp_s = erp;
        cfm_s = cfm;
    } else if (cfm > 0) {
        const double hkp = erp / substeps, kd = 1.0 - erp;  // h kp and kd, both times CFM
        erp_s = hkp / (hkp + kd);
        cfm_s = cfm / (hkp + kd);
    } else {
        erp_s = 1.0 - std::pow(1.0 - erp, 1.0 / substeps);
        cfm_s = 0;
    }
}

// The normal row's target velocity at a depth (ERP past the surface layer,
// capped, at least the bounce target).
inline double normal_target(double depth, const Kept& k, const RowInputs& in) {
    const double c = std::min(in.fps * k.erp * std::max(depth - in.surface_layer, 0.0), in.max_correcting_vel);
    return std::max(c, k.bounce);
}

void build_sphere_row(const ContactFrame& f, const RowInputs& in, SphereRow& K);
// The row's effective masses: SOR w / (J inv(M) J^T + cfm) of the normal row
// and of the friction rows, from its lever lengths and the two bodies'
// inverse masses and inertias (0 for a static partner), as the build keeps
// them for the relaxation; or from the bodies' rows.
void sphere_row_masses(const SphereRow& K, double invm1, double invi1, double invm2, double invi2,
                       const SphereRowConstants& c, double& ad_n, double& ad_t);
void sphere_row_masses(const SphereRow& K, const BodyRow& B1, const BodyRow& B2, const SphereRowConstants& c,
                       double& ad_n, double& ad_t);
void build_block(const ContactFrame& f, const RowInputs& in, Block& K);
// The right-hand sides for velocity terms tmp = v / h + inv(M) f_ext (tmp2
// null when static) and the normal row's target c0 (the friction rows' is 0).
void sphere_rhs(SphereRow& K, const double* tmp1, const double* tmp2, double c0, double fps);

// Impulses in, velocity corrections out (warm start).
void apply_impulses(const SphereRow& K, BodyRow* bodies);
void apply_impulses(const Block& K, BodyRow* bodies);

namespace detail {
inline double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double clamp_row(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }
inline void cross3(const double* a, const double* b, double* out) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}
// out = M v, M row-major 3x3.
inline void mul33(const double* M, const double* v, double* out) {
    for (int r = 0; r < 3; ++r) out[r] = M[3 * r] * v[0] + M[3 * r + 1] * v[1] + M[3 * r + 2] * v[2];
}

// Doubles side by side in one register (GCC/Clang vector extension): two in
// SSE2's, four in AVX's. The lanes are computed with the same IEEE operations,
// in the same order, as a double alone. Everything a lane computation calls
// is forced inline, so that the AVX instantiation is compiled for AVX inside
// its AVX entry point and nowhere else.
#define PARODE_LANE_INLINE __attribute__((always_inline)) inline
using Pair = double __attribute__((vector_size(16)));
using Quad = double __attribute__((vector_size(32)));
using Oct = double __attribute__((vector_size(64)));
template <class V>
constexpr int lanes() { return static_cast<int>(sizeof(V) / sizeof(double)); }
template <class V>
PARODE_LANE_INLINE void set_lane(V& v, int l, double x) {
    if constexpr (lanes<V>() == 1) v = x;
    else v[l] = x;
}
template <class V>
PARODE_LANE_INLINE double lane(const V& v, int l) {
    if constexpr (lanes<V>() == 1) return v;
    else return v[l];
}
template <class V>
PARODE_LANE_INLINE V splat(double x) {
    V v;
    for (int l = 0; l < lanes<V>(); ++l) set_lane(v, l, x);
    return v;
}
template <class V>
PARODE_LANE_INLINE V dot(const V* a, const V* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
template <class V>
PARODE_LANE_INLINE V clamp(V v, V lo, V hi) { return v < lo ? lo : (v > hi ? hi : v); }
// Lane l of the result is get(l). A function, not a lambda: a lambda is not
// forced inline nor compiled for its enclosing function's AVX target, so
// where it is not inlined (-O0) it would return an AVX register through the
// non-AVX calling convention (AddressSanitizer caught the mismatch).
template <class V, int L, class Get>
PARODE_LANE_INLINE V gather_lanes(Get get) {
    V v;
    for (int l = 0; l < L; ++l) set_lane(v, l, get(l));
    return v;
}
template <class V>
PARODE_LANE_INLINE V abs(V v) { return v < splat<V>(0.0) ? -v : v; }
template <class V>
PARODE_LANE_INLINE V max(V a, V b) { return a < b ? b : a; }
// A record's block `at` (four doubles, Quad, or two, Pair, from the byte
// offset), read or written in one go through a type of the doubles' own
// alignment (one 32-byte load for a Quad:
// a memcpy was expanded as two 16-byte halves through the stack.)
template <class V>
struct UnalignedOf;
template <>
struct UnalignedOf<Quad> {
    using type = double __attribute__((vector_size(32), aligned(8), may_alias));
};
template <>
struct UnalignedOf<Pair> {
    using type = double __attribute__((vector_size(16), aligned(8), may_alias));
};
template <class V>
using Unaligned = typename UnalignedOf<V>::type;
template <class V, class T>
PARODE_LANE_INLINE V block_at(const T* rec, std::size_t at) {
    return *reinterpret_cast<const Unaligned<V>*>(reinterpret_cast<const char*>(rec) + at);
}

template <class V, class T>
PARODE_LANE_INLINE void store_block(T* rec, std::size_t at, const V& v) {
    *reinterpret_cast<Unaligned<V>*>(reinterpret_cast<char*>(rec) + at) = v;
}
// Eight records' blocks of four doubles (a[l]: record l's) as four vectors of
// eight lanes (out[i][l] = a[l][i]): records l and l + 4 joined in one
// register, then two levels of two-source shuffles; untranspose8 is the
// inverse. Only for V = Oct, inside the AVX-512 entry point (relax_eight).
template <class V>
PARODE_LANE_INLINE void transpose8(const Quad* a, V* out) {
    V z[4], t[4];
    for (int i = 0; i < 4; ++i) z[i] = __builtin_shufflevector(a[i], a[i + 4], 0, 1, 2, 3, 4, 5, 6, 7);
    t[0] = __builtin_shufflevector(z[0], z[1], 0, 8, 2, 10, 4, 12, 6, 14);
    t[1] = __builtin_shufflevector(z[0], z[1], 1, 9, 3, 11, 5, 13, 7, 15);
    t[2] = __builtin_shufflevector(z[2], z[3], 0, 8, 2, 10, 4, 12, 6, 14);
    t[3] = __builtin_shufflevector(z[2], z[3], 1, 9, 3, 11, 5, 13, 7, 15);
    out[0] = __builtin_shufflevector(t[0], t[2], 0, 1, 8, 9, 4, 5, 12, 13);
    out[1] = __builtin_shufflevector(t[1], t[3], 0, 1, 8, 9, 4, 5, 12, 13);
    out[2] = __builtin_shufflevector(t[0], t[2], 2, 3, 10, 11, 6, 7, 14, 15);
    out[3] = __builtin_shufflevector(t[1], t[3], 2, 3, 10, 11, 6, 7, 14, 15);
}
template <class V>
PARODE_LANE_INLINE void untranspose8(const V* v, Quad* a) {
    V t[4], o[4];
    t[0] = __builtin_shufflevector(v[0], v[1], 0, 8, 2, 10, 4, 12, 6, 14);
    t[1] = __builtin_shufflevector(v[0], v[1], 1, 9, 3, 11, 5, 13, 7, 15);
    t[2] = __builtin_shufflevector(v[2], v[3], 0, 8, 2, 10, 4, 12, 6, 14);
    t[3] = __builtin_shufflevector(v[2], v[3], 1, 9, 3, 11, 5, 13, 7, 15);
    o[0] = __builtin_shufflevector(t[0], t[2], 0, 1, 8, 9, 4, 5, 12, 13);    // lanes 0 | 4
    o[1] = __builtin_shufflevector(t[1], t[3], 0, 1, 8, 9, 4, 5, 12, 13);    // lanes 1 | 5
    o[2] = __builtin_shufflevector(t[0], t[2], 2, 3, 10, 11, 6, 7, 14, 15);  // lanes 2 | 6
    o[3] = __builtin_shufflevector(t[1], t[3], 2, 3, 10, 11, 6, 7, 14, 15);  // lanes 3 | 7
    for (int i = 0; i < 4; ++i) {
        a[i] = __builtin_shufflevector(o[i], o[i], 0, 1, 2, 3);
        a[i + 4] = __builtin_shufflevector(o[i], o[i], 4, 5, 6, 7);
    }
}
// Four records' blocks of four doubles as four vectors of four lanes: each
// register joins the same half of records l and l + 2 as it is loaded (a
// 16-byte load and an insert from memory), then one unpack within the
// 128-bit halves gives each lane vector, and back again, a half at a time.
// No shuffle crosses the halves: a cross-half shuffle (vperm2f128) is one
// operation on Intel but eight on AMD's first 256-bit cores (Zen 1), where
// the 25 of a pack of four made the solve 1.03 to 1.10 x slower
// (analysis/results/vm-amd-epyc-2c/four-lane-halves).
template <class T>
PARODE_LANE_INLINE Quad join_halves(const T* a, const T* b, std::size_t at) {
    return __builtin_shufflevector(block_at<Pair>(a, at), block_at<Pair>(b, at), 0, 1, 2, 3);
}
template <class T>
PARODE_LANE_INLINE void load_four(const T* const* rec, std::size_t at, Quad* out) {
    const Quad a = join_halves(rec[0], rec[2], at), b = join_halves(rec[1], rec[3], at);
    const Quad c = join_halves(rec[0], rec[2], at + 16), d = join_halves(rec[1], rec[3], at + 16);
    out[0] = __builtin_shufflevector(a, b, 0, 4, 2, 6);
    out[1] = __builtin_shufflevector(a, b, 1, 5, 3, 7);
    out[2] = __builtin_shufflevector(c, d, 0, 4, 2, 6);
    out[3] = __builtin_shufflevector(c, d, 1, 5, 3, 7);
}
// Four lane vectors written back as each record's block, a half at a time:
// one unpack within the halves gives records 0 and 2 (1 and 3) side by side,
// the low half stored as it is and the high half copied out of the register
// (an extract: GCC 12 lowers a shuffle of the high half as a cross-half
// permute first).
template <class T>
PARODE_LANE_INLINE void store_halves(T* lo_rec, T* hi_rec, std::size_t at, Quad q) {
    Pair high;
    std::memcpy(&high, reinterpret_cast<const char*>(&q) + sizeof(Pair), sizeof(Pair));
    store_block(lo_rec, at, Pair(__builtin_shufflevector(q, q, 0, 1)));
    store_block(hi_rec, at, high);
}
// Records get their block `at` back from four lane vectors.
template <class T>
PARODE_LANE_INLINE void store_four(T* const* rec, std::size_t at, const Quad* v) {
    store_halves(rec[0], rec[2], at, __builtin_shufflevector(v[0], v[1], 0, 4, 2, 6));
    store_halves(rec[1], rec[3], at, __builtin_shufflevector(v[0], v[1], 1, 5, 3, 7));
    store_halves(rec[0], rec[2], at + 16, __builtin_shufflevector(v[2], v[3], 0, 4, 2, 6));
    store_halves(rec[1], rec[3], at + 16, __builtin_shufflevector(v[2], v[3], 1, 5, 3, 7));
}
// Records get four lane vectors added to their block `at` (Whole = false:
// only to its first half, v[0], v[1]), a half at a time as store_four writes
// a block: read from `from`, written to `to` (the same records, or for one not
// written a row of zeros read and a scratch row written).
template <class T>
PARODE_LANE_INLINE void add_halves(const T* from_lo, const T* from_hi, T* to_lo, T* to_hi, std::size_t at, Quad q) {
    store_halves(to_lo, to_hi, at, join_halves(from_lo, from_hi, at) + q);
}
template <bool Whole, class T>
PARODE_LANE_INLINE void add_four(const T* const* from, T* const* to, std::size_t at, const Quad* v) {
    add_halves(from[0], from[2], to[0], to[2], at, __builtin_shufflevector(v[0], v[1], 0, 4, 2, 6));
    add_halves(from[1], from[3], to[1], to[3], at, __builtin_shufflevector(v[0], v[1], 1, 5, 3, 7));
    if constexpr (Whole) {
        add_halves(from[0], from[2], to[0], to[2], at + 16, __builtin_shufflevector(v[2], v[3], 0, 4, 2, 6));
        add_halves(from[1], from[3], to[1], to[3], at + 16, __builtin_shufflevector(v[2], v[3], 1, 5, 3, 7));
    }
}
// Block `at` of each of lanes<V>() (four or eight) records, as four vectors
// of lanes; and (eight lanes) four vectors of lanes as each lane's block.
template <class V, class T>
PARODE_LANE_INLINE void load_blocks(const T* const* rec, std::size_t at, V* out) {
    if constexpr (lanes<V>() == 8) {
        Quad in[8];
        for (int l = 0; l < 8; ++l) in[l] = block_at<Quad>(rec[l], at);
        transpose8(in, out);
    } else {
        load_four(rec, at, out);
    }
}
// Square root lane by lane; SSE2 square roots on x86-64 (IEEE square
// roots are correctly rounded: the same bits as std::sqrt, without its errno
// branch per lane).
template <class V>
PARODE_LANE_INLINE V root(V v) {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    if constexpr (lanes<V>() == 4) {  // two SSE2 halves: an AVX builtin would need AVX here too
        const Pair a = __builtin_ia32_sqrtpd(Pair{v[0], v[1]}), b = __builtin_ia32_sqrtpd(Pair{v[2], v[3]});
        return V{a[0], a[1], b[0], b[1]};
    } else if constexpr (lanes<V>() == 2) {
        return __builtin_ia32_sqrtpd(v);
    }
#endif
    V r;
    for (int l = 0; l < lanes<V>(); ++l) set_lane(r, l, std::sqrt(lane(v, l)));
    return r;
}
}  // namespace detail

// The effective masses of a sphere row, SOR w / (J inv(M) J^T + cfm), from
// m = invm1 + invm2 and k = r1 (invi1 r1) + r2 (invi2 r2): the same bits
// as the build's sums (m2 and k2 are zero for a static partner, and x + 0 is
// x). The build (sphere_row_masses) computes them here.
template <class V>
PARODE_LANE_INLINE void effective_masses(V m, V k, const SphereRowConstants& c, V& ad_n, V& ad_t) {
    using detail::splat;
    const V cfm = splat<V>(c.cfm), w = splat<V>(c.sor_w);
    ad_n = w / (m + cfm);
    ad_t = w / (m + k + cfm);
}

// Unit tangents t1, t2 = n x t1 of a unit normal n, as ODE's dPlaneSpace
// builds them (t1 in the y-z plane when |n_z| > sqrt(1/2), else in x-y), the
// same bits whether a lane of V or a double. The scale k = 1 / sqrt(a) of
// the projection a they normalise comes from tangent_scale.
template <class V>
PARODE_LANE_INLINE auto tangent_plane(const V* n, V& a) {
    using namespace detail;
    const auto yz = abs(n[2]) > splat<V>(0.70710678118654752440);
    a = yz ? n[1] * n[1] + n[2] * n[2] : n[0] * n[0] + n[1] * n[1];
    return yz;
}
template <class V>
PARODE_LANE_INLINE V tangent_scale(const V* n) {
    V a;
    tangent_plane(n, a);
    return detail::splat<V>(1.0) / detail::root(a);
}
template <class V>
PARODE_LANE_INLINE void tangent_frame(const V* n, V k, V* t1, V* t2) {
    using namespace detail;
    const V zero = splat<V>(0.0);
    V a;
    const auto yz = tangent_plane(n, a);
    t1[0] = yz ? zero : -n[1] * k;
    t1[1] = yz ? -n[2] * k : n[0] * k;
    t1[2] = yz ? n[1] * k : zero;
    t2[0] = yz ? a * k : -n[2] * t1[1];
    t2[1] = yz ? -n[0] * t1[2] : n[2] * t1[0];
    t2[2] = yz ? n[0] * t1[1] : a * k;
}

// Four or eight bodies' rows (fc[0..3] | fc[4], fc[5], invm, invi) read as
// two blocks each and transposed into lanes.
template <class V>
PARODE_LANE_INLINE void load_lanes(const BodyRow* const* B, V* f, V& invm, V& invi) {
    V b[4];
    detail::load_blocks(B, 0, f);
    detail::load_blocks(B, 4 * sizeof(double), b);
    f[4] = b[0], f[5] = b[1], invm = b[2], invi = b[3];
}
// What eight lanes write back: each row's lambda (with its mu, unchanged)
// as one block, each body's corrections with its unchanged invm and invi as
// a second block; a static partner's not at all.
template <class V>
PARODE_LANE_INLINE void store_eight_lanes(SphereRow* const* K, BodyRow* bodies, V n0, V n1, V n2, V mu, const V* f1, V m1,
                                    V i1, const V* f2, V m2, V i2) {
    constexpr int L = detail::lanes<V>();
    static_assert(L == 8, "four lanes write back through add_four_lanes");
    constexpr std::size_t half = 4 * sizeof(double);
    const V rows[4] = {n0, n1, n2, mu}, h1[4] = {f1[4], f1[5], m1, i1}, h2[4] = {f2[4], f2[5], m2, i2};
    detail::Quad out[L], lo1[L], hi1[L], lo2[L], hi2[L];
    detail::untranspose8(rows, out);
    detail::untranspose8(f1, lo1);
    detail::untranspose8(h1, hi1);
    detail::untranspose8(f2, lo2);
    detail::untranspose8(h2, hi2);
    for (int l = 0; l < L; ++l) {
        BodyRow* b1 = &bodies[K[l]->b1];
        detail::store_block(K[l], offsetof(SphereRow, lambda), out[l]);
        detail::store_block(b1, 0, lo1[l]);
        detail::store_block(b1, half, hi1[l]);
        if (K[l]->b2 < 0) continue;
        BodyRow* b2 = &bodies[K[l]->b2];
        detail::store_block(b2, 0, lo2[l]);
        detail::store_block(b2, half, hi2[l]);
    }
}

// What four lanes write back: each row's lambda (with its mu) as one block,
// and each body's corrections as the changes p1, p2 added to what its row
// holds (fc + p rounds as the update fc += p in lanes does, so the bits are
// the same): the bodies' corrections need not stay in registers through
// the three rows (16 AVX registers: they were spilled to the stack and read
// back). B1, B2: the body rows relax_lanes read, written through the same
// pointers; B2 is `none` for a static partner, whose changes go to a
// scratch row. A template (V = Quad), so that it is compiled only inside
// the AVX entry point.
template <class V>
PARODE_LANE_INLINE void add_four_lanes(SphereRow* const* K, const BodyRow* const* B1, const BodyRow* const* B2,
                                       const BodyRow* none, const V* rows, const V* p1, const V* p2) {
    constexpr std::size_t half = 4 * sizeof(double);
    BodyRow scratch;  // written, never read
    BodyRow* b1[4];
    BodyRow* b2[4];
    for (int l = 0; l < 4; ++l) {
        b1[l] = const_cast<BodyRow*>(B1[l]);
        b2[l] = B2[l] == none ? &scratch : const_cast<BodyRow*>(B2[l]);
    }
    detail::store_four(K, offsetof(SphereRow, lambda), rows);
    detail::add_four<true>(b1, b1, 0, p1);
    detail::add_four<false>(b1, b1, half, p1 + 4);  // fc[4], fc[5]: invm and invi stay
    detail::add_four<true>(B2, b2, 0, p2);
    detail::add_four<false>(B2, b2, half, p2 + 4);
}

// The relative velocity terms u, w of relax_lanes from both bodies'
// corrections.
template <class V>
PARODE_LANE_INLINE void relative_terms(const V* f1, const V* f2, V r1, V r2, V* u, V* w) {
    for (int i = 0; i < 3; ++i) {
        u[i] = f1[i] - f2[i];
        w[i] = r1 * f1[3 + i] + r2 * f2[3 + i];
    }
}

// One projected Gauss-Seidel update of every row of L sphere contacts that
// share no body (one per lane of V: double for one, detail::Pair for two,
// detail::Quad for four, detail::Oct for eight), bit for bit what each would
// give alone. The rows act on the relative
// velocity terms u = fc1_lin - fc2_lin and w = r1 fc1_ang + r2 fc2_ang only,
// so u and w are updated in registers row by row (exactly the rows' own
// effect) and the bodies' corrections once at the end: a short dependency
// chain instead of a round trip through memory per row. A static partner
// reads as a body at rest with zero inverse mass; the friction rows of a
// frictionless contact are clamped to zero: every lane runs the same code.
// `change`: null, or where each lane's change goes (L doubles): m1 + m2
// times the largest change of its three impulses, the largest change of a
// relative velocity term it made (times the step: m/s), which the active
// sweeps compare with their tolerance.
template <class V, int L>
PARODE_LANE_INLINE void relax_lanes(SphereRow* const* K, BodyRow* bodies, const SphereRowConstants& c,
                                    double* change = nullptr) {
    using namespace detail;
    static const BodyRow none{};
    const BodyRow* B1[L];
    const BodyRow* B2[L];
    for (int l = 0; l < L; ++l) {
        B1[l] = &bodies[K[l]->b1];
        B2[l] = K[l]->b2 >= 0 ? &bodies[K[l]->b2] : &none;
    }
    V f1[6], f2[6], n[3], t1[3], t2[3], rhs[3], lam[3], r1, r2, m1, m2, i1, i2, mu, ad_n, ad_t, kt;
    V u[3], w[3];
    if constexpr (L == 4 || L == 8) {
        // In the order they are used: the bodies' corrections folded into
        // u, w as soon as both are read (then dead), the impulses and
        // effective masses after: fewer registers live at once, fewer
        // spilled.
        V b[4];
        load_blocks(K, offsetof(SphereRow, n), b);
        n[0] = b[0], n[1] = b[1], n[2] = b[2], r1 = b[3];
        load_blocks(K, offsetof(SphereRow, r2), b);
        r2 = b[0], rhs[0] = b[1], rhs[1] = b[2], rhs[2] = b[3];
        load_lanes(B1, f1, m1, i1);
        load_lanes(B2, f2, m2, i2);
        relative_terms(f1, f2, r1, r2, u, w);
        load_blocks(K, offsetof(SphereRow, lambda), b);
        lam[0] = b[0], lam[1] = b[1], lam[2] = b[2], mu = b[3];
        load_blocks(K, offsetof(SphereRow, ad_n), b);
        ad_n = b[0], ad_t = b[1], kt = b[2];  // b[3]: the slots' bits, unused
    } else {
        for (int i = 0; i < 6; ++i) {
            f1[i] = gather_lanes<V, L>([&](int l) { return B1[l]->fc[i]; });
            f2[i] = gather_lanes<V, L>([&](int l) { return B2[l]->fc[i]; });
        }
        for (int i = 0; i < 3; ++i) n[i] = gather_lanes<V, L>([&](int l) { return K[l]->n[i]; });
        r1 = gather_lanes<V, L>([&](int l) { return K[l]->r1; }), r2 = gather_lanes<V, L>([&](int l) { return K[l]->r2; });
        m1 = gather_lanes<V, L>([&](int l) { return B1[l]->invm; }), m2 = gather_lanes<V, L>([&](int l) { return B2[l]->invm; });
        i1 = gather_lanes<V, L>([&](int l) { return B1[l]->invi; }), i2 = gather_lanes<V, L>([&](int l) { return B2[l]->invi; });
        mu = gather_lanes<V, L>([&](int l) { return K[l]->mu; });
        ad_n = gather_lanes<V, L>([&](int l) { return K[l]->ad_n; });
        ad_t = gather_lanes<V, L>([&](int l) { return K[l]->ad_t; });
        kt = gather_lanes<V, L>([&](int l) { return K[l]->kt; });
        for (int r = 0; r < 3; ++r) {
            rhs[r] = gather_lanes<V, L>([&](int l) { return K[l]->rhs[r]; });
            lam[r] = gather_lanes<V, L>([&](int l) { return K[l]->lambda[r]; });
        }
        relative_terms(f1, f2, r1, r2, u, w);
    }
    const V k1 = i1 * r1, k2 = i2 * r2;
    const V m = m1 + m2, k = r1 * k1 + r2 * k2, zero = splat<V>(0.0);
    const V cfm = splat<V>(c.cfm);
    // Normal row: no angular part.
    V x = lam[0] + ad_n * (rhs[0] - cfm * lam[0] - dot(n, u));
    const V n0 = x < zero ? zero : x;
    const V d0 = n0 - lam[0];
    for (int i = 0; i < 3; ++i) u[i] += d0 * m * n[i];
    const V hi = abs(mu * n0), lo = -hi;
    tangent_frame(n, kt, t1, t2);  // here, not at the start: six registers fewer through the normal row
    // Row t1: angular direction -t2.
    x = lam[1] + ad_t * (rhs[1] - cfm * lam[1] - (dot(t1, u) - dot(t2, w)));
    const V n1 = clamp(x, lo, hi);
    const V d1 = n1 - lam[1];
    for (int i = 0; i < 3; ++i) {
        u[i] += d1 * m * t1[i];
        w[i] -= d1 * k * t2[i];
    }
    // Row t2: angular direction t1.
    x = lam[2] + ad_t * (rhs[2] - cfm * lam[2] - (dot(t2, u) + dot(t1, w)));
    const V n2 = clamp(x, lo, hi);
    const V d2 = n2 - lam[2];
    if (change) {
        const V big = m * max(abs(d0), max(abs(d1), abs(d2)));
        for (int l = 0; l < L; ++l) change[l] = lane(big, l);
    }
    V dl[3], da[3];
    for (int i = 0; i < 3; ++i) {
        dl[i] = d0 * n[i] + (d1 * t1[i] + d2 * t2[i]);
        da[i] = d2 * t1[i] - d1 * t2[i];
    }
    if constexpr (L == 4) {  // f1 - m2 dl is f1 + (-m2) dl, bit for bit
        const V nm2 = -m2, rows[4] = {n0, n1, n2, mu};
        V p1[6], p2[6];
        for (int i = 0; i < 3; ++i) {
            p1[i] = m1 * dl[i];
            p1[3 + i] = k1 * da[i];
            p2[i] = nm2 * dl[i];
            p2[3 + i] = k2 * da[i];
        }
        add_four_lanes(K, B1, B2, &none, rows, p1, p2);
        return;
    }
    for (int i = 0; i < 3; ++i) {
        f1[i] += m1 * dl[i];
        f1[3 + i] += k1 * da[i];
        f2[i] -= m2 * dl[i];
        f2[3 + i] += k2 * da[i];
    }
    if constexpr (L == 8) {
        store_eight_lanes(K, bodies, n0, n1, n2, mu, f1, m1, i1, f2, m2, i2);
        return;
    }
    for (int l = 0; l < L; ++l) {
        K[l]->lambda[0] = lane(n0, l);
        K[l]->lambda[1] = lane(n1, l);
        K[l]->lambda[2] = lane(n2, l);
        BodyRow& b1 = bodies[K[l]->b1];
        for (int i = 0; i < 6; ++i) b1.fc[i] = lane(f1[i], l);
        if (K[l]->b2 < 0) continue;
        BodyRow& b2 = bodies[K[l]->b2];
        for (int i = 0; i < 6; ++i) b2.fc[i] = lane(f2[i], l);
    }
}

inline void relax(SphereRow& K, BodyRow* bodies, const SphereRowConstants& c, double* change = nullptr) {
    SphereRow* one = &K;
    relax_lanes<double, 1>(&one, bodies, c, change);
}

// Four contacts that share no body, in the four lanes of an AVX register when
// the processor has AVX (bit for bit the same as two pairs).
void relax_four(SphereRow* const* K, BodyRow* bodies, const SphereRowConstants& c, double* change = nullptr);
// Whether relax_four uses AVX; tests may turn it off to compare.
bool four_lanes();
void set_four_lanes(bool on);
// Eight contacts that share no body, in the eight lanes of an AVX-512
// register when the processor has AVX-512F, else as two fours (the same
// bits either way).
void relax_eight(SphereRow* const* K, BodyRow* bodies, const SphereRowConstants& c, double* change = nullptr);
// Whether relax_eight uses AVX-512; tests may turn it off to compare.
bool eight_lanes();
void set_eight_lanes(bool on);

inline void relax(Block& K, BodyRow* bodies, double* change = nullptr) {
    double* f1 = bodies[K.b1].fc;
    double* f2 = K.b2 >= 0 ? bodies[K.b2].fc : nullptr;
    if (change) *change = 0;
    for (int row = 0; row < K.rows; ++row) {
        const double* J = K.J[row];
        double delta = K.rhs[row] - K.lambda[row] * K.cfm[row] - detail::dot3(J, f1) - detail::dot3(J + 3, f1 + 3);
        if (f2) delta -= detail::dot3(J + 6, f2) + detail::dot3(J + 9, f2 + 3);
        const double hi = row == 0 ? HUGE_VAL : std::fabs(K.mu * K.lambda[0]);
        const double lo = row == 0 ? 0.0 : -hi;
        const double old = K.lambda[row];
        const double nl = detail::clamp_row(old + delta, lo, hi);
        delta = nl - old;
        K.lambda[row] = nl;
        const double* iMJ = K.iMJ[row];
        for (int i = 0; i < 6; ++i) f1[i] += delta * iMJ[i];
        if (f2) {
            for (int i = 0; i < 6; ++i) f2[i] += delta * iMJ[6 + i];
        }
        for (int i = 0; change && i < 3; ++i) {
            *change = std::max(*change, std::fabs(delta * (iMJ[i] - (f2 ? iMJ[6 + i] : 0.0))));
        }
    }
}

}  // namespace parode
