// World construction from a Scene (see world.hpp).
#include "world/world.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <stdexcept>

#include "scene/generators.hpp"

namespace parode {
namespace {

constexpr unsigned long kDynamicCategory = 1;
constexpr unsigned long kStaticCategory = 2;
constexpr unsigned long kGhostCategory = 4;

dSpaceID make_space(SpaceKind kind) {
    switch (kind) {
        case SpaceKind::Hash: return dHashSpaceCreate(nullptr);
        case SpaceKind::SweepAndPrune: return dSweepAndPruneSpaceCreate(nullptr, dSAP_AXES_XYZ);
        case SpaceKind::Simple: break;
    }
    return dSimpleSpaceCreate(nullptr);
}

dMass mass_for(const BodySpec& s) {
    dMass m;
    const Shape& sh = s.shape;
    switch (sh.kind) {
        case ShapeKind::Sphere: dMassSetSphereTotal(&m, s.mass, sh.radius); break;
        case ShapeKind::Box: dMassSetBoxTotal(&m, s.mass, sh.size[0], sh.size[1], sh.size[2]); break;
        case ShapeKind::Capsule: dMassSetCapsuleTotal(&m, s.mass, 3, sh.radius, sh.length); break;
        case ShapeKind::Cylinder: dMassSetCylinderTotal(&m, s.mass, 3, sh.radius, sh.length); break;
    }
    return m;
}

void place_geom(dGeomID g, const Vec3& p, const Quat& q) {
    dGeomSetPosition(g, p[0], p[1], p[2]);
    const dQuaternion dq{q[0], q[1], q[2], q[3]};
    dGeomSetQuaternion(g, dq);
}

// What place_geom does to a geom's body (ODE's geom setters call these).
void place_body(dBodyID b, const Vec3& p, const Quat& q) {
    dBodySetPosition(b, p[0], p[1], p[2]);
    const dQuaternion dq{q[0], q[1], q[2], q[3]};
    dBodySetQuaternion(b, dq);
}

void set_joint_param(dJointID id, JointKind kind, int code, double value) {
    switch (kind) {
        case JointKind::Hinge2: dJointSetHinge2Param(id, code, value); break;
        case JointKind::Hinge: dJointSetHingeParam(id, code, value); break;
        case JointKind::Ball: dJointSetBallParam(id, code, value); break;
        case JointKind::Fixed: dJointSetFixedParam(id, code, value); break;
    }
}

}  // namespace

void ensure_ode_initialised() {
    static std::once_flag once;
    std::call_once(once, [] {
        if (!dInitODE2(0)) throw std::runtime_error("ODE initialisation failed");
        dAllocateODEDataForThread(dAllocateMaskAll);
    });
}

World::World(const Scene& scene, SpaceKind space_kind, const std::vector<std::uint32_t>* gids)
    : scene_(scene), global_(scene.body_count()) {
    ensure_ode_initialised();
    drand_seed_ = static_cast<unsigned long>(scene.seed);
    world_ = dWorldCreate();
    space_ = make_space(space_kind);
    contacts_ = dJointGroupCreate(0);
    const SolverSpec& s = scene.solver;
    dWorldSetGravity(world_, scene.gravity[0], scene.gravity[1], scene.gravity[2]);
    dWorldSetERP(world_, s.erp);
    dWorldSetCFM(world_, s.cfm);
    dWorldSetQuickStepNumIterations(world_, s.iterations);
    dWorldSetQuickStepW(world_, s.sor_w);
    dWorldSetContactSurfaceLayer(world_, s.contact_surface_layer);
    dWorldSetContactMaxCorrectingVel(world_, s.contact_max_correcting_vel);
    dWorldSetAutoDisableFlag(world_, s.auto_disable ? 1 : 0);
    dWorldSetAutoDisableLinearThreshold(world_, s.auto_disable_linear);
    dWorldSetAutoDisableAngularThreshold(world_, s.auto_disable_angular);
    dWorldSetAutoDisableSteps(world_, s.auto_disable_steps);
    dWorldSetAutoDisableTime(world_, 0);
    // Without auto-disable no body averages its velocity: no sample buffers
    // (two allocations a body, 64 bytes of ODE's 1 KB per body).
    if (!s.auto_disable) dWorldSetAutoDisableAverageSamplesCount(world_, 0);
    const std::size_t n = gids ? gids->size() : global_;
    map_.reset(global_, n);
    reserve_bodies(n);
    for (const BodySpec& b : scene.bodies) body_mass_.push_back(mass_for(b));
    catom_mass_ = mass_for(scene.catoms.proto);
    build_statics();
    for (std::size_t i = 0; i < n; ++i) add_body(gids ? (*gids)[i] : static_cast<std::uint32_t>(i), false);
    learn_record_lines();
    describe_spheres();
    build_joints();
    build_surfaces();
}

World::~World() {
    dJointGroupDestroy(contacts_);
    dSpaceDestroy(space_);  // destroys the geoms it holds
    dWorldDestroy(world_);  // destroys bodies and joints
}

dGeomID World::make_geom(const Shape& s) {
    switch (s.kind) {
        case ShapeKind::Sphere: return dCreateSphere(space_, s.radius);
        case ShapeKind::Box: return dCreateBox(space_, s.size[0], s.size[1], s.size[2]);
        case ShapeKind::Capsule: return dCreateCapsule(space_, s.radius, s.length);
        case ShapeKind::Cylinder: break;
    }
    return dCreateCylinder(space_, s.radius, s.length);
}

// The byte range of a body's record that dBodyGet{Position,Rotation,
// Quaternion,LinearVel,AngularVel,Force,Torque} point into, from one body
// made for the purpose (every record has the same layout): an address every
// 64 bytes from its first byte, and its last byte, so that every line it
// covers is fetched wherever the record starts; and the byte of its flags
// (dBodyGetGravityMode reads them), found as the one byte that turning
// gravity off changes among the record's first 64.
void World::learn_record_lines() {
    dBodyID b = dBodyCreate(world_);
    const char* base = reinterpret_cast<const char*>(b);
    const dReal* parts[7] = {dBodyGetPosition(b),   dBodyGetRotation(b), dBodyGetQuaternion(b), dBodyGetLinearVel(b),
                             dBodyGetAngularVel(b), dBodyGetForce(b),    dBodyGetTorque(b)};
    const std::ptrdiff_t sizes[7] = {3, 12, 4, 3, 3, 3, 3};
    std::ptrdiff_t lo = PTRDIFF_MAX, hi = 0;
    for (int p = 0; p < 7; ++p) {
        const std::ptrdiff_t at = reinterpret_cast<const char*>(parts[p]) - base;
        lo = std::min(lo, at);
        hi = std::max(hi, at + sizes[p] * static_cast<std::ptrdiff_t>(sizeof(dReal)) - 1);
    }
    unsigned char head[64];
    std::memcpy(head, base, sizeof head);
    dBodySetGravityMode(b, 0);
    std::ptrdiff_t flags = -1;
    for (std::ptrdiff_t k = 0; k < 64 && flags < 0; ++k) flags = head[k] != static_cast<unsigned char>(base[k]) ? k : -1;
    dBodyDestroy(b);
    record_lines_ = 0;
    if (flags >= 0 && flags < lo) record_line_[record_lines_++] = flags;
    for (std::ptrdiff_t at = lo; at <= hi && record_lines_ < 7; at += 64) record_line_[record_lines_++] = at;
    record_line_[record_lines_++] = hi;
}

void World::reserve_bodies(std::size_t n) {
    if (n <= bodies_.capacity()) return;
    n += n / 8;
    bodies_.reserve(n);
    gids_.reserve(n);
    ghost_.reserve(n);
    q_in_.reserve(n);
    origin_.reserve(n);
    slot_.reserve(n);
    geoms_.reserve(n + (geoms_.size() - bodies_.size()));  // the statics follow the bodies
}

std::size_t World::add_body(std::uint32_t gid, bool ghost, const BodyState* state, const Vec3* origin) {
    const BodySpec s = scene_.body(gid);
    const std::size_t local = bodies_.size();
    dBodyID b = dBodyCreate(world_);
    dBodySetMass(b, &mass_of(gid));  // ODE copies it: what mass_of returns, bit for bit
    place_body(b, s.position, s.orientation);
    dBodySetLinearVel(b, s.velocity[0], s.velocity[1], s.velocity[2]);
    dBodySetAngularVel(b, s.angular_velocity[0], s.angular_velocity[1], s.angular_velocity[2]);
    bodies_.push_back(b);
    gids_.push_back(gid);
    ghost_.push_back(0);
    q_in_.push_back({s.orientation[0], s.orientation[1], s.orientation[2], s.orientation[3]});
    origin_.push_back(origin ? *origin : s.position);
    slot_.emplace_back();
    geoms_.insert(geoms_.begin() + static_cast<std::ptrdiff_t>(local), nullptr);
    ++geomless_;
    map_.set(gid, static_cast<std::uint32_t>(local));
    ++owned_;
    set_ghost(local, ghost);  // gives it the geom its role needs
    if (state) set_state(local, *state);
    ++generation_;
    return local;
}

void World::remove_body(std::size_t local) {
    const std::size_t last = bodies_.size() - 1;
    if (!ghost_[local]) --owned_;
    map_.erase(gids_[local]);
    if (geoms_[local]) dGeomDestroy(geoms_[local]);
    else --geomless_;
    dBodyDestroy(bodies_[local]);
    if (local != last) {
        bodies_[local] = bodies_[last];
        gids_[local] = gids_[last];
        ghost_[local] = ghost_[last];
        q_in_[local] = q_in_[last];
        origin_[local] = origin_[last];
        slot_[local] = slot_[last];
        geoms_[local] = geoms_[last];
        map_.set(gids_[local], static_cast<std::uint32_t>(local));
    }
    bodies_.pop_back();
    gids_.pop_back();
    ghost_.pop_back();
    q_in_.pop_back();
    origin_.pop_back();
    slot_.pop_back();
    geoms_.erase(geoms_.begin() + static_cast<std::ptrdiff_t>(last));
    ++generation_;
}

void World::set_ghost(std::size_t local, bool ghost) {
    if ((ghost_[local] != 0) != ghost) {
        if (ghost) --owned_;
        else ++owned_;
        ++generation_;  // who owns what changed: stage plans built on the old split are stale
        if (!ghost) {   // a ghost's forces were copies of its owner's; an owned body starts with none
            dBodySetForce(bodies_[local], 0, 0, 0);
            dBodySetTorque(bodies_[local], 0, 0, 0);
        }
    }
    ghost_[local] = ghost ? 1 : 0;
    fit_geom(local);
}

// An owned body always has its geom; a ghost has one unless ghost_geoms_ is
// off. A geom made for a body that has moved follows the body (dGeomSetBody
// takes the body's pose and marks the geom moved).
void World::fit_geom(std::size_t local) {
    const bool ghost = ghost_[local] != 0;
    dGeomID& g = geoms_[local];
    if (ghost && !ghost_geoms_) {
        if (g) {
            dGeomDestroy(g);
            g = nullptr;
            ++geomless_;
        }
        return;
    }
    if (!g) {
        g = make_geom(shape_of(gids_[local]));
        dGeomSetBody(g, bodies_[local]);
        set_geom_id(g, gids_[local]);
        --geomless_;
    }
    dGeomSetCategoryBits(g, ghost ? kGhostCategory : kDynamicCategory);
    dGeomSetCollideBits(g, ghost ? kDynamicCategory : ~0UL);
}

void World::set_ghost_geoms(bool on) {
    if (!on && !bodies_are_spheres()) {
        throw std::logic_error("World::set_ghost_geoms(false): a ghost without a geom collides only through "
                               "the sphere hint, and this scene has bodies that are not spheres");
    }
    ghost_geoms_ = on;
    for (std::size_t i = 0; i < bodies_.size(); ++i) {
        if (ghost_[i]) fit_geom(i);
    }
}

BodyState World::state(std::size_t local) const {
    BodyState s;
    dBodyID b = bodies_[local];
    const dReal* x = dBodyGetPosition(b);
    const dReal* v = dBodyGetLinearVel(b);
    const dReal* w = dBodyGetAngularVel(b);
    for (int k = 0; k < 3; ++k) {
        s.x[k] = x[k];
        s.v[k] = v[k];
        s.w[k] = w[k];
    }
    for (int k = 0; k < 4; ++k) s.q[k] = q_in_[local][static_cast<std::size_t>(k)];
    return s;
}

void World::set_state(std::size_t local, const BodyState& s) {
    set_pose(local, s.x, s.q);
    dBodySetLinearVel(bodies_[local], s.v[0], s.v[1], s.v[2]);
    dBodySetAngularVel(bodies_[local], s.w[0], s.w[1], s.w[2]);
}

void World::set_pose(std::size_t local, const double x[3], const double q[4]) {
    dBodyID b = bodies_[local];
    dBodySetPosition(b, x[0], x[1], x[2]);
    const dQuaternion dq = {q[0], q[1], q[2], q[3]};
    dBodySetQuaternion(b, dq);
    for (int k = 0; k < 4; ++k) q_in_[local][static_cast<std::size_t>(k)] = q[k];
}

// ODE 0.16.2's dBodySetQuaternion normalises with dNormalize4 and fills the
// rotation with dQtoR (not exported): the same products in the same order,
// so that the bits agree (test_world_pose compares them with ODE's setter).
void World::write_pose(std::size_t local, const double x[3], const double q[4]) {
    dBodyID b = bodies_[local];
    auto* pos = const_cast<dReal*>(dBodyGetPosition(b));
    auto* bq = const_cast<dReal*>(dBodyGetQuaternion(b));
    auto* R = const_cast<dReal*>(dBodyGetRotation(b));
    for (int k = 0; k < 3; ++k) pos[k] = x[k];
    for (int k = 0; k < 4; ++k) bq[k] = q[k];
    dNormalize4(bq);
    const dReal qq1 = 2 * bq[1] * bq[1], qq2 = 2 * bq[2] * bq[2], qq3 = 2 * bq[3] * bq[3];
    R[0] = 1 - qq2 - qq3;
    R[1] = 2 * (bq[1] * bq[2] - bq[0] * bq[3]);
    R[2] = 2 * (bq[1] * bq[3] + bq[0] * bq[2]);
    R[3] = 0;
    R[4] = 2 * (bq[1] * bq[2] + bq[0] * bq[3]);
    R[5] = 1 - qq1 - qq3;
    R[6] = 2 * (bq[2] * bq[3] - bq[0] * bq[1]);
    R[7] = 0;
    R[8] = 2 * (bq[1] * bq[3] - bq[0] * bq[2]);
    R[9] = 2 * (bq[2] * bq[3] + bq[0] * bq[1]);
    R[10] = 1 - qq1 - qq2;
    R[11] = 0;
    for (int k = 0; k < 4; ++k) q_in_[local][static_cast<std::size_t>(k)] = q[k];
}

void World::mark_moved(std::size_t local) {
    for (dGeomID g = dBodyGetFirstGeom(bodies_[local]); g; g = dBodyGetNextGeom(g)) dGeomMoved(g);
}

void World::mark_moved_owned() {
    const std::size_t end = bodies_.size();
    constexpr std::size_t kBodyAhead = 16, kGeomAhead = 8;  // the geom's address is read from its body
    const auto warm = [](const void* p) {
        __builtin_prefetch(p, 1);
        __builtin_prefetch(static_cast<const char*>(p) + 64, 1);
    };
    for (std::size_t i = 0; i < end; ++i) {
        if (i + kBodyAhead < end) warm(bodies_[i + kBodyAhead]);
        if (i + kGeomAhead < end) {
            if (dGeomID g = dBodyGetFirstGeom(bodies_[i + kGeomAhead])) warm(g);
        }
        if (!ghost(i)) mark_moved(i);
    }
}

void World::poses_written() {
    if (defer_moves_) {
        moves_pending_ = true;
        return;
    }
    mark_moved_owned();
}

void World::defer_moves(bool on) {
    if (!on) sync_moves();
    defer_moves_ = on;
}

void World::sync_moves() {
    if (!moves_pending_) return;
    mark_moved_owned();
    moves_pending_ = false;
}

bool World::bodies_are_spheres() const {
    const auto sphere = [](const BodySpec& b) { return b.shape.kind == ShapeKind::Sphere; };
    return std::all_of(scene_.bodies.begin(), scene_.bodies.end(), sphere) &&
           (scene_.catoms.count == 0 || sphere(scene_.catoms.proto));
}

// The radii and bits add_body and set_ghost give the body geoms.
void World::describe_spheres() {
    if (!bodies_are_spheres()) return;
    for (const BodySpec& b : scene_.bodies) spheres_.body_radius.push_back(b.shape.radius);
    spheres_.catom_radius = scene_.catoms.proto.shape.radius;
    spheres_.category[0] = kDynamicCategory;
    spheres_.collide[0] = ~0UL;
    spheres_.category[1] = kGhostCategory;
    spheres_.collide[1] = kDynamicCategory;
    spheres_.bodies = &bodies_;
    spheres_.ids = &gids_;
    spheres_.ghost = &ghost_;
    spheres_.geomless = &geomless_;
}

bool World::restore_state(std::size_t local, const BodyState& s, const double ode_q[4]) {
    set_state(local, s);
    const dReal* q = dBodyGetQuaternion(bodies_[local]);
    return q[0] == ode_q[0] && q[1] == ode_q[1] && q[2] == ode_q[2] && q[3] == ode_q[3];
}

void World::settle_quaternions() {
    for (std::size_t i = 0; i < bodies_.size(); ++i) {
        const dReal* q = dBodyGetQuaternion(bodies_[i]);
        const dQuaternion in = {q[0], q[1], q[2], q[3]};
        for (int k = 0; k < 4; ++k) q_in_[i][static_cast<std::size_t>(k)] = in[k];
        dBodySetQuaternion(bodies_[i], in);
    }
}

const dMass& World::mass_of(std::uint32_t gid) const {
    return gid < body_mass_.size() ? body_mass_[gid] : catom_mass_;
}

int World::material_of(std::uint32_t geom_id) const {
    if (geom_id < global_) {
        return geom_id < scene_.bodies.size() ? scene_.bodies[geom_id].material : scene_.catoms.proto.material;
    }
    return static_material_[geom_id - global_];
}

const Shape& World::shape_of(std::uint32_t gid) const {
    return gid < scene_.bodies.size() ? scene_.bodies[gid].shape : scene_.catoms.proto.shape;
}

World::GeomShape World::geom_shape(std::uint32_t geom_id) const {
    const Shape* s = nullptr;
    if (geom_id < global_) {
        s = &shape_of(geom_id);
    } else if (geom_id - global_ < scene_.statics.size()) {
        s = &scene_.statics[geom_id - global_].shape;
    } else {
        return GeomShape::Plane;
    }
    switch (s->kind) {
        case ShapeKind::Sphere: return GeomShape::Sphere;
        case ShapeKind::Box: return GeomShape::Box;
        case ShapeKind::Capsule: return GeomShape::Capsule;
        case ShapeKind::Cylinder: break;
    }
    return GeomShape::Cylinder;
}

void World::build_statics() {
    auto add = [this](dGeomID g, int material) {
        set_geom_id(g, static_cast<std::uint32_t>(global_ + static_material_.size()));
        dGeomSetCategoryBits(g, kStaticCategory);
        dGeomSetCollideBits(g, kDynamicCategory);
        geoms_.push_back(g);
        static_material_.push_back(material);
    };
    for (const StaticGeom& s : scene_.statics) {
        dGeomID g = make_geom(s.shape);
        place_geom(g, s.position, s.orientation);
        add(g, s.material);
    }
    for (const PlaneSpec& p : scene_.planes) {
        add(dCreatePlane(space_, p.normal[0], p.normal[1], p.normal[2], p.offset), p.material);
    }
}

void World::build_joints() {
    for (const JointSpec& j : scene_.joints) {
        dJointID id = nullptr;
        switch (j.kind) {
            case JointKind::Hinge2: id = dJointCreateHinge2(world_, nullptr); break;
            case JointKind::Hinge: id = dJointCreateHinge(world_, nullptr); break;
            case JointKind::Ball: id = dJointCreateBall(world_, nullptr); break;
            case JointKind::Fixed: id = dJointCreateFixed(world_, nullptr); break;
        }
        auto held = [this](int gid) {
            const std::uint32_t local = gid >= 0 ? map_.find(static_cast<std::uint32_t>(gid)) : IdMap::kNone;
            return local == IdMap::kNone ? nullptr : bodies_[local];
        };
        dJointAttach(id, held(j.body_a), held(j.body_b));
        const Vec3& a = j.anchor;
        switch (j.kind) {
            case JointKind::Hinge2: {
                dJointSetHinge2Anchor(id, a[0], a[1], a[2]);
                const dReal ax1[3] = {j.axis1[0], j.axis1[1], j.axis1[2]};
                const dReal ax2[3] = {j.axis2[0], j.axis2[1], j.axis2[2]};
                dJointSetHinge2Axes(id, ax1, ax2);
                break;
            }
            case JointKind::Hinge:
                dJointSetHingeAnchor(id, a[0], a[1], a[2]);
                dJointSetHingeAxis(id, j.axis1[0], j.axis1[1], j.axis1[2]);
                break;
            case JointKind::Ball: dJointSetBallAnchor(id, a[0], a[1], a[2]); break;
            case JointKind::Fixed: dJointSetFixed(id); break;
        }
        for (const auto& p : j.params) set_joint_param(id, j.kind, joint_param_code(p.first), p.second);
        joints_.push_back(id);
    }
}

void World::build_surfaces() {
    const auto& mats = scene_.materials;
    const std::size_t n = mats.size();
    surfaces_.assign(n * n, dSurfaceParameters{});
    for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t k = 0; k < n; ++k) {
            const Material& a = mats[i];
            const Material& b = mats[k];
            dSurfaceParameters s{};
            s.mode = dContactApprox1;
            s.mu = std::sqrt(a.mu * b.mu);
            if (a.bounce > 0 || b.bounce > 0) {
                s.mode |= dContactBounce;
                s.bounce = std::max(a.bounce, b.bounce);
                s.bounce_vel = std::max(a.bounce_vel, b.bounce_vel);
            }
            if (a.soft_erp >= 0 || b.soft_erp >= 0) {
                s.mode |= dContactSoftERP;
                s.soft_erp = std::max(a.soft_erp, b.soft_erp);
            }
            if (a.soft_cfm >= 0 || b.soft_cfm >= 0) {
                s.mode |= dContactSoftCFM;
                s.soft_cfm = std::max(a.soft_cfm, b.soft_cfm);
            }
            if (a.slip > 0 || b.slip > 0) {
                s.mode |= dContactSlip1 | dContactSlip2;
                s.slip1 = s.slip2 = std::max(a.slip, b.slip);
            }
            surfaces_[i * n + k] = s;
        }
    }
}

const dSurfaceParameters& World::surface(int a, int b) const {
    return surfaces_[static_cast<std::size_t>(a) * scene_.materials.size() + static_cast<std::size_t>(b)];
}

dGeomID World::geom_of(std::uint32_t id) const {
    if (id < global_) return geoms_[local_of(id)];
    return geoms_[bodies_.size() + (id - global_)];
}

dBodyID World::body_of_geom(std::uint32_t id) const { return id < global_ ? bodies_[local_of(id)] : nullptr; }

bool World::joined(dBodyID b1, dBodyID b2) const {
    return !joints_.empty() && b1 && b2 && dAreConnectedExcluding(b1, b2, dJointTypeContact);
}

bool World::ignores(const ContactRecord& c) const { return !joints_.empty() && joined(body_of_geom(c.lo), body_of_geom(c.hi)); }

void World::create_contact_joints(const ContactBuffer& contacts) {
    for (std::size_t k = 0; k < contacts.size(); ++k) {
        const ContactRecord& r = contacts.items()[k];
        const dBodyID b1 = body_of_geom(r.lo), b2 = body_of_geom(r.hi);
        if (joined(b1, b2)) continue;
        dContact c;
        c.surface = surface(material_of(r.lo), material_of(r.hi));
        c.geom = contacts.ode(k, geom_of(r.lo), geom_of(r.hi));
        c.fdir1[0] = c.fdir1[1] = c.fdir1[2] = c.fdir1[3] = 0;
        dJointID j = dJointCreateContact(world_, contacts_, &c);
        dJointAttach(j, b1, b2);
    }
}

}  // namespace parode
