// Sphere-sphere and sphere-plane contacts computed from compact copies of the
// geoms' data, giving exactly what dCollide(lower id, higher id) writes: the same
// arithmetic, in the same order, with ODE's own inline vector helpers, and the
// same argument swap (normal negated) when the plane comes first.
// Trade-off: saves ODE's dispatch and two scattered geom reads per pair, at the
// price of depending on ODE's formulas for these two pairs; the omp tests check
// every contact against dCollide bit for bit. The touch tests the narrowphase
// runs on every candidate give fast_contact's outcome, deciding most pairs
// from the squares alone (sphere_squares: the square root only at the edge).
// This file must be compiled without floating-point contraction
// (-ffp-contract=off), as ODE is.
#pragma once
#include <ode/ode.h>

#include <cstdint>
#include <limits>

#include "collide/contacts.hpp"

namespace parode::omp {

// What the narrowphase needs of a sphere or a plane, copied once per call.
struct PrimData {
    dGeomID geom;
    std::uint32_t id;
    std::uint32_t flags;  // the geom's GeomFlag bits (geom_info.hpp)
    dReal p[4];  // sphere: centre (p[0..2]) and radius (p[3]); plane: a, b, c, d
};

// dCollide(s1, s2) for two spheres, s1 given first. Returns the contact count
// (0 or 1) and fills `c` as ODE does.
inline int sphere_sphere(const PrimData& s1, const PrimData& s2, ContactRecord& r) {
    ContactPoint& c = r.geom;
    const dReal r1 = s1.p[3];
    const dReal r2 = s2.p[3];
    // The squared distance exactly as dCalcPointsDistance3 sums it; its correctly
    // rounded square root is ODE's d. Pairs clearly apart (beyond a relative
    // margin far above rounding) are rejected before the square root: for them
    // ODE's d > r1 + r2 holds as well.
    dVector3 diff;
    dSubtractVectors3(diff, s1.p, s2.p);
    const dReal d2 = diff[0] * diff[0] + diff[1] * diff[1] + diff[2] * diff[2];
    const dReal sum = r1 + r2;
    if (d2 > sum * sum * REAL(1.0000000001) && sum >= 0) return 0;
    const dReal d = dSqrt(d2);
    if (d > sum) return 0;
    if (d <= 0) {
        for (int k = 0; k < 3; ++k) c.pos[k] = s1.p[k];
        c.normal[0] = 1;
        c.normal[1] = 0;
        c.normal[2] = 0;
        c.depth = r1 + r2;
        return 1;
    }
    const dReal inv = dRecip(d);
    for (int k = 0; k < 3; ++k) c.normal[k] = (s1.p[k] - s2.p[k]) * inv;
    const dReal half = REAL(0.5) * (r2 - r1 - d);
    for (int k = 0; k < 3; ++k) c.pos[k] = s1.p[k] + c.normal[k] * half;
    c.depth = r1 + r2 - d;
    return 1;
}

// The sphere-plane contact as ODE's sphere/plane collider computes it with the
// sphere first. Returns 0 or 1.
inline int sphere_plane(const PrimData& s, const PrimData& pl, ContactRecord& r) {
    ContactPoint& c = r.geom;
    const dReal radius = s.p[3];
    const dReal k = dCalcVectorDot3(s.p, pl.p);
    const dReal depth = pl.p[3] - k + radius;
    if (!(depth >= 0)) return 0;
    for (int j = 0; j < 3; ++j) c.normal[j] = pl.p[j];
    for (int j = 0; j < 3; ++j) c.pos[j] = s.p[j] - pl.p[j] * radius;
    c.depth = depth;
    return 1;
}

// dCollide(plane, sphere): the sphere-first result seen from the plane's side.
inline int plane_sphere(const PrimData& pl, const PrimData& s, ContactRecord& r) {
    if (sphere_plane(s, pl, r) == 0) return 0;
    for (int j = 0; j < 3; ++j) r.geom.normal[j] = -r.geom.normal[j];
    return 1;
}

// The contact of a sphere/sphere or sphere/plane pair in canonical order (the
// lower id is dCollide's first argument), into `out`; false if none.
inline bool fast_contact(const PrimData& a, bool a_sphere, const PrimData& b, bool b_sphere, int max_contacts,
                         ContactRecord& out) {
    if (max_contacts < 1 || a.geom == b.geom) return false;  // dCollide: nothing, as ODE
    const bool a_first = !(b.id < a.id);  // as ContactBuffer::collide_pair
    const PrimData& first = a_first ? a : b;
    const PrimData& second = a_first ? b : a;
    const bool first_sphere = a_first ? a_sphere : b_sphere;
    const bool second_sphere = a_first ? b_sphere : a_sphere;
    int n = 0;  // every field of out is written when a contact is returned
    if (first_sphere && second_sphere) {
        n = sphere_sphere(first, second, out);
    } else if (first_sphere) {
        n = sphere_plane(first, second, out);
    } else {
        n = plane_sphere(first, second, out);
    }
    out.lo = first.id;
    out.hi = second.id;
    return n == 1;
}

// Appends the contact of a sphere/sphere or sphere/plane pair to `out`.
// (Sides: -1, as ODE's sphere and plane colliders write them.)
inline void append_fast_pair(const PrimData& a, bool a_sphere, const PrimData& b, bool b_sphere,
                             int max_contacts, ContactBuffer& out) {
    ContactRecord r;
    if (fast_contact(a, a_sphere, b, b_sphere, max_contacts, r)) out.push(r);
}

// What the squares tell of two spheres against fast_contact's test d <= r1 +
// r2, d the correctly rounded square root of d2 (ODE's dCollideSpheres):
// `near` (they touch), `far` (they do not: fast_contact rejects the pair
// before its square root), or neither (the edge: the square root decides).
// Near: d2 <= (sum * sum)(1 - 1e-10) rounded, sum * sum a normal number above
// 2^-900 (no underflow, no overflow). Then d2 < sum^2 exactly (two roundings
// of some 1e-16 against the 1e-10 margin), so sqrt(d2) < sum and its
// rounding is at most sum. Also |x1 - x2| < r1 + r2 exactly on every axis
// (diff, its square and the sum each lose at most a few 1e-16; a square
// below the normal range means an axis far shorter than sum), so ODE's
// sphere AABBs (x -+ r, rounded) overlap: rounding is monotonic. A pair with
// a NaN, negative radii or sum * sum outside that range is at the edge.
struct SquaresVerdict {
    bool near, far;
    dReal d2, sum;
};
inline SquaresVerdict sphere_squares(const PrimData& a, const PrimData& b) {
    dVector3 diff;
    dSubtractVectors3(diff, a.p, b.p);
    SquaresVerdict v;
    v.d2 = diff[0] * diff[0] + diff[1] * diff[1] + diff[2] * diff[2];
    v.sum = a.p[3] + b.p[3];
    const dReal sum2 = v.sum * v.sum;
    v.far = (v.d2 > sum2 * REAL(1.0000000001)) & (v.sum >= 0);
    const bool in_range = (sum2 >= REAL(0x1p-900)) & (sum2 <= std::numeric_limits<dReal>::max());
    v.near = (v.d2 <= sum2 * REAL(0.9999999999)) & (v.sum >= 0) & in_range;
    return v;
}

// Whether a verdict needs the square root (neither near nor far), tested as
// one value: the compiler would otherwise branch on `near` and on `far`
// apart, each close to random in a pile.
inline bool at_the_edge(const SquaresVerdict& v) {
    unsigned known = static_cast<unsigned>(v.near) | static_cast<unsigned>(v.far);
#if defined(__GNUC__) || defined(__clang__)
    asm("" : "+r"(known));  // opaque: known is tested as one value
#endif
    return __builtin_expect(known == 0, 0);
}

// fast_contact's own test at the edge.
inline bool edge_touch(const SquaresVerdict& v) { return !v.far & !(dSqrt(v.d2) > v.sum); }

// Whether fast_contact finds a contact: the same tests without building it,
// and without a branch on their outcome. Both tests are symmetric in their
// arguments, bit for bit. Two spheres: the square root only at the edge
// (measured at 10^6 catoms: otherwise one for each of 3 million listed pairs
// a step).
inline bool fast_touch(const PrimData& a, bool a_sphere, const PrimData& b, bool b_sphere) {
    if (a_sphere && b_sphere) {
        const SquaresVerdict v = sphere_squares(a, b);
        return at_the_edge(v) ? edge_touch(v) : v.near;
    }
    const PrimData& s = a_sphere ? a : b;
    const PrimData& pl = a_sphere ? b : a;
    return pl.p[3] - dCalcVectorDot3(s.p, pl.p) + s.p[3] >= 0;
}

}  // namespace parode::omp
