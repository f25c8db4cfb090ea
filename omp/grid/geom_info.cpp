// Reading geoms into the geom table (see geom_info.hpp): class, enabled and
// zero-size state as ODE's spaces judge it, AABB, body, bits, id and the data of
// the sphere/plane fast paths.
// Trade-off: every getter is a call into ODE; they run once per geom per call,
// spread over tasks, instead of once per candidate pair. Where the caller
// describes its body spheres (SphereBodies, collide.hpp), only the body's
// position is read from ODE: one record a geom instead of two and a dozen
// calls, at the price of trusting the description (World's, tested against
// this reading in test_omp_determinism).
#include "omp/grid/geom_info.hpp"
#include "omp/runtime/task_split.hpp"

#include <algorithm>
#include <cmath>

namespace parode::omp {
namespace {

// ODE's spaces skip geoms whose size parameters make them zero-sized.
bool zero_sized(dGeomID g, int cls) {
    dReal r = 0, l = 0;
    switch (cls) {
        case dSphereClass: return dGeomSphereGetRadius(g) == 0;
        case dBoxClass: {
            dVector3 s;
            dGeomBoxGetLengths(g, s);
            return s[0] == 0 || s[1] == 0 || s[2] == 0;
        }
        case dCapsuleClass: dGeomCapsuleGetParams(g, &r, &l); return r == 0;
        case dCylinderClass: dGeomCylinderGetParams(g, &r, &l); return r == 0 || l == 0;
        default: return false;
    }
}

std::uint32_t class_flags(dGeomID g, int cls) {
    if (dGeomIsSpace(g)) return kSpace;
    if (cls >= dFirstUserClass) return kUser;
    switch (cls) {
        case dSphereClass: return kSafe | kSphere;
        case dPlaneClass: return kSafe | kPlane;
        case dBoxClass:
        case dCapsuleClass:
        case dCylinderClass:
        case dRayClass: return kSafe;
        default: return kUnsafe;
    }
}

void read_prim(dGeomID g, std::uint32_t flags, PrimData& p) {
    p.geom = g;
    p.id = geom_id(g);
    p.flags = flags;
    if (flags & kSphere) {
        const dReal* pos = dGeomGetPosition(g);
        for (int k = 0; k < 3; ++k) p.p[k] = pos[k];
        p.p[3] = dGeomSphereGetRadius(g);
    } else if (flags & kPlane) {
        dVector4 params;
        dGeomPlaneGetParams(g, params);
        for (int k = 0; k < 4; ++k) p.p[k] = params[k];
    } else {
        std::fill(p.p, p.p + 4, dReal(0));
    }
}

void read_extent(GeomFull& info) {
    bool finite = true;
    for (int k = 0; k < 6; ++k) finite = finite && std::isfinite(info.aabb[k]);
    info.extent = 0;
    if (!finite) return;
    info.flags |= kFinite;
    info.extent = aabb_extent(info.aabb);
}

// Bits the flags give back exactly (GeomView::full): below 0xff, or all ones.
// 0xff itself fits the flags for the packed test, but reads back as all ones,
// which differs against a geom with wide bits.
bool bits_recoverable(unsigned long bits) { return bits < 0xff || bits == ~0ul; }

// A sphere without offset whose bits the flags give back exactly: the table
// keeps no more than its GeomInfo.
bool plain_sphere(const GeomFull& g, bool offset) {
    return (g.flags & kSphere) && !(g.flags & (kWideBits | kStaleAabb)) && bits_recoverable(g.category) &&
           bits_recoverable(g.collide) && !offset;
}

// The rest of read_geom once the class, prim, enabled state and body are
// known: bits, AABB, extent and where the table keeps them.
void finish_geom(GeomFull& info, bool enabled, unsigned long category, unsigned long collide, bool offset) {
    if (enabled) info.flags |= kEnabled;
    info.category = category;
    info.collide = collide;
    if (info.category != ~0ul || info.collide != ~0ul) info.flags |= kCustomBits;
    info.flags |= pack_bits(info.category, info.collide);
    // ODE's formula on the position and radius read_prim took from ODE: the
    // same bits as dGeomGetAABB, current even when nobody told the space that
    // the sphere's body moved (World::defer_moves), and no write to the geom.
    if ((info.flags & kSphere) && !offset) {
        sphere_aabb(info.prim.p, info.aabb);
    } else {
        dGeomGetAABB(info.prim.geom, info.aabb);
    }
    read_extent(info);
    if (!plain_sphere(info, offset)) info.flags |= kAux;
    info.prim.flags = info.flags;
}

}  // namespace

GeomFull read_geom(dGeomID g, bool primitives_only) {
    GeomFull info;
    const int cls = dGeomGetClass(g);
    info.flags = class_flags(g, cls);
    if (primitives_only && !(info.flags & kSafe)) {
        if (dGeomIsEnabled(g) && !zero_sized(g, cls)) info.flags |= kEnabled;
        info.flags |= kStaleAabb;
        info.prim.geom = g;
        info.prim.flags = info.flags;
        info.body = nullptr;
        return info;
    }
    read_prim(g, info.flags, info.prim);  // a sphere's position and radius, read once
    const bool zero = (info.flags & kSphere) ? info.prim.p[3] == 0 : zero_sized(g, cls);
    info.body = dGeomGetBody(g);
    finish_geom(info, dGeomIsEnabled(g) && !zero, dGeomGetCategoryBits(g), dGeomGetCollideBits(g),
                (info.flags & kSphere) && dGeomIsOffset(g));
    return info;
}

GeomFull hinted_sphere(dGeomID g, const SphereBodies& s, std::size_t i) {
    GeomFull info;
    info.flags = kSafe | kSphere;
    info.prim.geom = g;
    info.prim.id = (*s.ids)[i];
    info.body = (*s.bodies)[i];
    const dReal* pos = dBodyGetPosition(info.body);
    for (int k = 0; k < 3; ++k) info.prim.p[k] = pos[k];
    info.prim.p[3] = s.radius(info.prim.id);
    const std::uint8_t ghost = (*s.ghost)[i] ? 1 : 0;
    finish_geom(info, info.prim.p[3] != 0, s.category[ghost], s.collide[ghost], false);
    return info;
}

void GeomTable::resize(std::size_t n) {
    info_.resize(n);
    scratch_resize(aux_, n);  // no element is touched until a geom needs it
}

void GeomTable::set(GeomInfo* info, GeomAux* aux, std::size_t i, const GeomFull& g) {
    GeomInfo r;
    r.prim = g.prim;
    r.prim.flags = g.flags;
    r.body = g.body;
    info[i] = r;
    if (!(g.flags & kAux)) return;
    GeomAux& a = aux[i];
    std::copy(g.aabb, g.aabb + 6, a.aabb);
    a.category = g.category;
    a.collide = g.collide;
    a.extent = g.extent;
}

GeomFull GeomView::full(std::size_t i) const {
    GeomFull g;
    const GeomInfo& r = info[i];
    g.prim = r.prim;
    g.flags = r.prim.flags;
    g.body = r.body;
    aabb(i, g.aabb);
    g.extent = extent(i);
    if (g.flags & kAux) {
        g.category = aux[i].category;
        g.collide = aux[i].collide;
    } else {  // bits below 0xff or all ones (plain_sphere): their low bytes, as pack_bits keeps them
        g.category = (g.flags >> 16) & 0xff;
        g.collide = (g.flags >> 24) & 0xff;
        if (g.category == 0xff) g.category = ~0ul;
        if (g.collide == 0xff) g.collide = ~0ul;
    }
    return g;
}

void refresh_stale(GeomTable& infos) {
    for (std::size_t i = 0; i < infos.size(); ++i) {
        if (!(infos[i].prim.flags & kStaleAabb)) continue;
        dGeomID g = infos[i].prim.geom;
        if (dGeomIsSpace(g)) dSpaceClean(reinterpret_cast<dSpaceID>(g));
        infos.set(i, read_geom(g));
    }
}

void list_space(dSpaceID space, std::vector<dGeomID>& out) {
    const int n = dSpaceGetNumGeoms(space);
    out.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) out[static_cast<std::size_t>(i)] = dSpaceGetGeom(space, i);
}

namespace {

// Geoms ahead whose record read_range prefetches, and whose body's position
// (where a sphere's AABB is computed from) it prefetches, reading the body's
// address from the geom fetched earlier.
constexpr std::size_t kGeomAhead = 16, kBodyAhead = 8;

void prefetch_record(const void* p) {
    __builtin_prefetch(p);
    __builtin_prefetch(static_cast<const char*>(p) + 64);
}

// Reads geoms [begin, end) of src into dst; returns the union of their flags.
// Geoms below `hinted` take their data from `spheres` and their body's
// position alone from ODE.
std::uint32_t read_range(const dGeomID* src, GeomInfo* dst, GeomAux* aux, std::size_t begin, std::size_t end,
                         const SphereBodies* spheres, std::size_t hinted) {
    std::uint32_t f = 0;
    for (std::size_t i = begin; i < end; ++i) {
        const std::size_t body_ahead = i + kBodyAhead;
        if (body_ahead < hinted && body_ahead < end) {
            __builtin_prefetch(dBodyGetPosition((*spheres->bodies)[body_ahead]));
        } else if (i + kGeomAhead < end) {
            prefetch_record(src[i + kGeomAhead]);
            if (body_ahead < end) {
                if (dBodyID b = dGeomGetBody(src[body_ahead])) __builtin_prefetch(dBodyGetPosition(b));
            }
        }
        const GeomFull g = i < hinted ? hinted_sphere(src[i], *spheres, i) : read_geom(src[i], true);
        GeomTable::set(dst, aux, i, g);
        f |= g.flags;
    }
    return f;
}

std::uint32_t union_of(const std::vector<std::uint32_t>& flags) {
    std::uint32_t all = 0;
    for (std::uint32_t f : flags) all |= f;
    return all;
}

}  // namespace

// Each task keeps the union of the flags it read in its own entry; the union
// over tasks is serial (a few hundred entries, not a pass over the table).
std::uint32_t read_geoms(const std::vector<dGeomID>& geoms, GeomTable& out, const SphereBodies* spheres) {
    const std::size_t n = geoms.size();
    out.resize(geoms.size());
    GeomInfo* dst = out.data();
    GeomAux* aux = out.aux();
    const dGeomID* src = geoms.data();
    const std::size_t hinted = spheres ? std::min(n, spheres->bodies->size()) : 0;
    const std::size_t blocks = task_count(n, 1024);
    std::vector<std::uint32_t> any(blocks, 0);
    std::uint32_t* flags = any.data();
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(dst, aux, src, n, blocks, flags, spheres, hinted)
    for (std::size_t b = 0; b < blocks; ++b) {
        flags[b] = read_range(src, dst, aux, task_begin(n, blocks, b), task_begin(n, blocks, b + 1), spheres, hinted);
    }
    return union_of(any);
}

std::uint32_t read_space_pipelined(dSpaceID space, std::vector<dGeomID>& geoms,
                                   GeomTable& out) {
    const std::size_t n = static_cast<std::size_t>(dSpaceGetNumGeoms(space));
    geoms.resize(n);
    out.resize(n);
    const std::size_t blocks = task_count(n, 1024);
    std::vector<std::uint32_t> any(blocks, 0);
    dGeomID* src = geoms.data();
    GeomInfo* dst = out.data();
    GeomAux* aux = out.aux();
    std::uint32_t* flags = any.data();
    for (std::size_t b = 0; b < blocks; ++b) {
        const std::size_t begin = task_begin(n, blocks, b), end = task_begin(n, blocks, b + 1);
        for (std::size_t i = begin; i < end; ++i) src[i] = dSpaceGetGeom(space, static_cast<int>(i));
#pragma omp task default(none) firstprivate(src, dst, aux, flags, b, begin, end)
        flags[b] = read_range(src, dst, aux, begin, end, nullptr, 0);
    }
#pragma omp taskwait
    return union_of(any);
}

}  // namespace parode::omp
