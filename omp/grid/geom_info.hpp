// One compact record per geom, read from ODE once per call, and the pair filter
// that ODE's spaces apply before their near-callback (collideAABBs): same body,
// category/collide bits, closed AABB overlap. Reading happens in parallel, so it
// requires every AABB to be current (dSpaceClean first): then the ODE getters
// used here only read.
// The table keeps one cache line per geom (GeomInfo: the narrowphase's data and
// the body). A plain sphere (no offset, bits below 0xff or all ones) needs nothing
// more: its AABB is ODE's formula on its centre and radius, recomputed where
// needed. Any other geom also has its AABB, extent and bits in a side table
// (GeomAux), which a scene of plain spheres never touches.
// Trade-off: a copy of 64 bytes per geom (a few flops more wherever an AABB is
// read) in exchange for never touching ODE's scattered geom memory again in the
// broadphase; the full 136-byte record cost three cache lines a geom in every
// pass over the table (measured at 10^6: docs/performance/million-catoms.md, "the geom table").
#pragma once
#include <ode/ode.h>

#include <cstdint>
#include <vector>

#include "collide/collide.hpp"
#include "omp/grid/fast_pairs.hpp"
#include "util/scratch.hpp"
#include "util/scratch_pool.hpp"

namespace parode::omp {

enum GeomFlag : std::uint32_t {
    kEnabled = 1u << 0,     // enabled and not zero-sized: ODE's spaces consider it
    kSphere = 1u << 1,      // sphere: fast path available
    kPlane = 1u << 2,       // plane: fast path available (with a sphere)
    kSafe = 1u << 3,        // primitive: dCollide may run concurrently
    kSpace = 1u << 4,       // a nested space
    kUnsafe = 1u << 5,      // trimesh, heightfield, convex, transform: serial only
    kUser = 1u << 6,        // user class: its AABB test is unreachable, use ODE
    kCustomBits = 1u << 7,  // category or collide bits differ from all-ones
    kFinite = 1u << 8,      // AABB finite on all six sides
    kStaleAabb = 1u << 9,   // not a primitive: AABB left for the serial refresh
    kWideBits = 1u << 10,   // category or collide bits beyond what the flags hold
    kAux = 1u << 11,        // AABB, extent and bits in the side table (not a plain sphere)
};

// Whether a pair of these flags takes the exact sphere fast path.
inline bool fast_pair(std::uint32_t fa, std::uint32_t fb) {
    return ((fa & kSphere) && (fb & (kSphere | kPlane))) || ((fa & kPlane) && (fb & kSphere));
}

// Category and collide bits below 256 or all ones (ODE's default) ride in the
// flags' top 16 bits as their low 8 bits, so that the pair filter needs no
// other memory: for such values, `(a.category & b.collide) != 0` equals the
// same test on the low 8 bits (all ones keeps a non-zero low byte, and the
// other side's bits are below 256 or all ones too).
inline std::uint32_t pack_bits(unsigned long category, unsigned long collide) {
    const bool fits = (category < 256 || category == ~0ul) && (collide < 256 || collide == ~0ul);
    if (!fits) return kWideBits;
    return static_cast<std::uint32_t>(category & 0xff) << 16 | static_cast<std::uint32_t>(collide & 0xff) << 24;
}
inline bool packed_bits_pass(std::uint32_t fa, std::uint32_t fb) {
    return ((fa >> 16) & (fb >> 24) & 0xff) | ((fb >> 16) & (fa >> 24) & 0xff);
}

// Everything the pair filter needs of one geom, as read_geom returns it.
struct GeomFull {
    dReal aabb[6];  // ODE order: min x, max x, min y, max y, min z, max z
    dBodyID body;
    unsigned long category;
    unsigned long collide;
    std::uint32_t flags;
    dReal extent;   // largest side of the AABB (finite geoms)
    PrimData prim;  // geom, id, and sphere/plane parameters
};

// The table's record: prim.flags holds the GeomFlag bits.
struct alignas(64) GeomInfo {
    PrimData prim;
    dBodyID body;
};
static_assert(sizeof(GeomInfo) == 64, "one cache line a geom");

// What a geom other than a plain sphere keeps beside its GeomInfo.
struct GeomAux {
    GeomAux() {}  // left uninitialised: only the entries of such geoms are written
    dReal aabb[6];
    unsigned long category, collide;
    dReal extent;
};

// ODE's dxSphere::computeAABB on a centre and radius (p[0..2], p[3]): the same
// bits as dGeomGetAABB of a sphere without offset.
inline void sphere_aabb(const dReal p[4], dReal aabb[6]) {
    for (int k = 0; k < 3; ++k) {
        aabb[2 * k] = p[k] - p[3];
        aabb[2 * k + 1] = p[k] + p[3];
    }
}

// Largest side of a finite AABB, as read_geom computes it.
inline dReal aabb_extent(const dReal aabb[6]) {
    dReal e = 0;
    for (int k = 0; k < 3; ++k) e = e > aabb[2 * k + 1] - aabb[2 * k] ? e : aabb[2 * k + 1] - aabb[2 * k];
    return e;
}

// The geoms of one call: GeomInfo records in a scratch pool slot
// (util/scratch_pool.hpp), GeomAux entries at the same indices. Plain data
// pointers, so that tasks can take the table by value.
struct GeomView {
    const GeomInfo* info = nullptr;
    const GeomAux* aux = nullptr;
    std::uint32_t flags(std::size_t i) const { return info[i].prim.flags; }
    void aabb(std::size_t i, dReal out[6]) const {
        if (info[i].prim.flags & kAux) {
            for (int k = 0; k < 6; ++k) out[k] = aux[i].aabb[k];
        } else {
            sphere_aabb(info[i].prim.p, out);
        }
    }
    // The AABB's largest side; 0 unless kFinite.
    dReal extent(std::size_t i) const {
        if (!(info[i].prim.flags & kFinite)) return 0;
        if (info[i].prim.flags & kAux) return aux[i].extent;
        dReal b[6];
        sphere_aabb(info[i].prim.p, b);
        return aabb_extent(b);
    }
    GeomFull full(std::size_t i) const;
};

class GeomTable {
public:
    GeomTable(ScratchPool* pool, int slot) : info_(pool, slot) {}
    void set_pool(ScratchPool* pool) { info_.set_pool(pool); }
    // Contents undefined until set.
    void resize(std::size_t n);
    std::size_t size() const { return info_.size(); }
    const GeomInfo& operator[](std::size_t i) const { return info_[i]; }
    GeomView view() const { return GeomView{info_.data(), aux_.data()}; }
    GeomFull full(std::size_t i) const { return view().full(i); }
    // Stores geom i (its side entry too unless it is a plain sphere).
    void set(std::size_t i, const GeomFull& g) { set(info_.data(), aux_.data(), i, g); }
    static void set(GeomInfo* info, GeomAux* aux, std::size_t i, const GeomFull& g);
    GeomInfo* data() { return info_.data(); }
    GeomAux* aux() { return aux_.data(); }

private:
    ScratchArray<GeomInfo> info_;
    std::vector<GeomAux> aux_;
};

// Read one geom, bringing its AABB up to date (dGeomGetAABB; a sphere without
// offset: ODE's formula on its position and radius, so it is current even
// when ODE was not told that its body moved, World::defer_moves). With
// `primitives_only`, only primitive geoms are refreshed (safe concurrently:
// the call writes that geom alone); others get kStaleAabb for the serial
// refresh_stale(), since a nested space's AABB needs dSpaceClean first.
GeomFull read_geom(dGeomID g, bool primitives_only = false);

// The entry read_geom gives geom `g` = geom i of the flat list `s` describes
// (collide.hpp), from `s` and the position of its body alone.
GeomFull hinted_sphere(dGeomID g, const SphereBodies& s, std::size_t i);

// Serially refreshes and re-reads the kStaleAabb entries of `infos`.
void refresh_stale(GeomTable& infos);

// The geoms of a space in ODE's list order (serial: ODE's enumerator is stateful).
void list_space(dSpaceID space, std::vector<dGeomID>& out);

// read_geom over a list, as OpenMP tasks when called inside a parallel region;
// the geoms `spheres` describes (if not null) through hinted_sphere. Returns
// the union of all geoms' flags.
std::uint32_t read_geoms(const std::vector<dGeomID>& geoms, GeomTable& out, const SphereBodies* spheres = nullptr);

// list_space and read_geoms overlapped: the calling thread walks ODE's list
// (serial, one cache miss per geom in large spaces) and hands each listed
// block to a task that reads it while the walk goes on.
std::uint32_t read_space_pipelined(dSpaceID space, std::vector<dGeomID>& geoms,
                                   GeomTable& out);

// ODE's closed AABB overlap test (disjoint only if strictly separated).
// Evaluated without branches (bitwise or of the six comparisons): the outcome
// is close to random for neighbours in a pile, so branches mispredict.
inline bool aabb_overlap(const dReal* a, const dReal* b) {
    const bool apart = (a[0] > b[1]) | (a[1] < b[0]) | (a[2] > b[3]) | (a[3] < b[2]) |
                       (a[4] > b[5]) | (a[5] < b[4]);
    return !apart;
}

// ODE's AABB overlap test and fast_contact's test on two spheres without
// offset: the AABBs are built only at the edge, since a near verdict implies
// their overlap (sphere_squares).
inline bool spheres_overlap_and_touch(const PrimData& a, const PrimData& b) {
    const SquaresVerdict v = sphere_squares(a, b);
    if (!at_the_edge(v)) return v.near;
    dReal ba[6], bb[6];
    sphere_aabb(a.p, ba);
    sphere_aabb(b.p, bb);
    return aabb_overlap(ba, bb) & edge_touch(v);
}

// Body and category/collide tests of collideAABBs (AABB overlap tested apart).
inline bool body_and_bits_pass(const GeomFull& a, const GeomFull& b) {
    if (a.body && a.body == b.body) return false;
    if (((a.flags | b.flags) & kCustomBits) == 0) return true;
    return ((a.category & b.collide) || (b.category & a.collide));
}

// The complete collideAABBs filter.
inline bool ode_pair_filter(const GeomFull& a, const GeomFull& b) {
    return aabb_overlap(a.aabb, b.aabb) && body_and_bits_pass(a, b);
}

}  // namespace parode::omp
