// One compact record per geom, read from ODE once per call, and the pair filter
// that ODE's spaces apply before their near-callback (collideAABBs): same body,
// category/collide bits, closed AABB overlap. Reading happens in parallel, so it
// requires every AABB to be current (dSpaceClean first): then the ODE getters
// used here only read.
// Trade-off: a copy of ~120 bytes per geom, in exchange for never touching ODE's
// scattered geom memory again in the broadphase.
#pragma once
#include <ode/ode.h>

#include <cstdint>
#include <vector>

#include "fast_pairs.hpp"
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

struct GeomInfo {
    dReal aabb[6];  // ODE order: min x, max x, min y, max y, min z, max z
    dBodyID body;
    unsigned long category;
    unsigned long collide;
    std::uint32_t flags;
    dReal extent;   // largest side of the AABB (finite geoms)
    PrimData prim;  // geom, id, and sphere/plane parameters
};

// The geoms of one call, in a scratch pool slot (util/scratch_pool.hpp).
using GeomTable = ScratchArray<GeomInfo>;

// Read one geom, bringing its AABB up to date (dGeomGetAABB; a sphere without
// offset: ODE's formula on its position and radius, so it is current even
// when ODE was not told that its body moved, World::defer_moves). With
// `primitives_only`, only primitive geoms are refreshed (safe concurrently:
// the call writes that geom alone); others get kStaleAabb for the serial
// refresh_stale(), since a nested space's AABB needs dSpaceClean first.
GeomInfo read_geom(dGeomID g, bool primitives_only = false);

// Serially refreshes and re-reads the kStaleAabb entries of `infos`.
void refresh_stale(GeomTable& infos);

// The geoms of a space in ODE's list order (serial: ODE's enumerator is stateful).
void list_space(dSpaceID space, std::vector<dGeomID>& out);

// read_geom over a list, as OpenMP tasks when called inside a parallel region.
// Returns the union of all geoms' flags.
std::uint32_t read_geoms(const std::vector<dGeomID>& geoms, GeomTable& out);

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

// Body and category/collide tests of collideAABBs (AABB overlap tested apart).
inline bool body_and_bits_pass(const GeomInfo& a, const GeomInfo& b) {
    if (a.body && a.body == b.body) return false;
    if (((a.flags | b.flags) & kCustomBits) == 0) return true;
    return ((a.category & b.collide) || (b.category & a.collide));
}

// The complete collideAABBs filter.
inline bool ode_pair_filter(const GeomInfo& a, const GeomInfo& b) {
    return aabb_overlap(a.aabb, b.aabb) && body_and_bits_pass(a, b);
}

}  // namespace parode::omp
