// World: the ODE world, one space, and the bodies this process holds, each
// with its global id (gid: [[bodies]] first, then the catoms) apart from its
// local storage index. Identity and every order that a result depends on use
// gids; storage uses local indices (dense, in no particular order), and the
// gid <-> local maps follow bodies as they are added and removed. A body is
// owned here or a ghost (a read-only copy of a body owned by another
// process). Geom ids equal body gids; static geoms and planes follow all
// bodies (ids body_count .. of the whole scene), and every process holds all
// of them. ODE's dRand (QuickStep's reordering) is process-global in ODE:
// each World keeps its own seed, which ODE's steppers load before a step and
// store after it (drand_seed), so worlds stepped in turns in one process do
// not draw from each other's sequence.
// Collision filtering by category bits: owned geoms are category 1, static
// geoms category 2 (collide only with owned), ghost geoms category 4
// (collide only with owned), so static-static, ghost-ghost and ghost-static
// pairs are never tested. Where the collision backend reads every body
// sphere from sphere_bodies() alone (the grid), a ghost has no geom at all
// (set_ghost_geoms): an ODE body is all a copy needs there.
// Trade-off: one geom per body keeps ids trivial; bodies are removed by
// moving the last one into the gap, so local indices change on removal and
// nothing may keep a local index across a step.
#pragma once
#include <ode/ode.h>

#include <array>
#include <cstdint>
#include <vector>

#include "collide/collide.hpp"
#include "scene/scene.hpp"
#include "util/id_map.hpp"

namespace parode {

// ODE's global initialisation, once per process.
void ensure_ode_initialised();

// The kinematic state of a body as it travels between processes. `q` is the
// quaternion last handed to ODE: ODE normalises what it is given, so handing
// it the same input reproduces the body bit for bit.
struct BodyState {
    double x[3], q[4], v[3], w[3];
};

// What the domain knows of a body's place (its cell, the cell's owner and
// holders, under which partition), kept with the body as it moves in
// storage so that a body that stays in its cell needs no lookup.
struct DomainSlot {
    std::uint64_t cell = ~0ULL;
    const std::vector<int>* holders = nullptr;  // the ranks holding a copy of the cell's bodies (the domain's)
    std::int32_t owner = -1;
    std::uint8_t sides = 0;      // the neighbours of the cell its halo reaches (CellSpace::key with a reach)
    std::uint32_t epoch = ~0u;   // the partition the entry belongs to
    std::uint32_t stamp = 0;     // the domain's pass that found it current (0: none)
};

// How many bodies ahead the passes over every body fetch ODE's records
// (World::prefetch_body).
inline constexpr std::size_t kRecordAhead = 4;

class World {
public:
    // Builds every body of the scene (local index = gid), or only `gids`.
    World(const Scene& scene, SpaceKind space_kind, const std::vector<std::uint32_t>* gids = nullptr);
    World(Scene&&, SpaceKind, const std::vector<std::uint32_t>* = nullptr) = delete;  // keeps a reference to the scene
    ~World();
    World(const World&) = delete;
    World& operator=(const World&) = delete;

    const Scene& scene() const { return scene_; }
    dWorldID id() const { return world_; }
    dSpaceID space() const { return space_; }
    dJointGroupID contact_group() const { return contacts_; }

    // Local bodies: owned ones and ghosts.
    std::size_t body_count() const { return bodies_.size(); }
    std::size_t owned_count() const { return owned_; }
    dBodyID body(std::size_t local) const { return bodies_[local]; }
    const std::vector<dBodyID>& bodies() const { return bodies_; }
    std::uint32_t gid(std::size_t local) const { return gids_[local]; }
    const std::vector<std::uint32_t>& gids() const { return gids_; }
    bool ghost(std::size_t local) const { return ghost_[local] != 0; }
    // Local index of a gid, or IdMap::kNone when it is not held here.
    std::uint32_t local_of(std::uint32_t gid) const { return map_.find(gid); }
    // Bodies of the whole scene; geom ids below this are bodies.
    std::size_t global_body_count() const { return global_; }
    bool is_body_id(std::uint32_t id) const { return id < global_; }
    DomainSlot& slot(std::size_t local) { return slot_[local]; }
    const DomainSlot& slot(std::size_t local) const { return slot_[local]; }
    // Initial position of a local body (it travels with the body).
    const Vec3& origin(std::size_t local) const { return origin_[local]; }
    // Changes whenever a body is added, removed (local indices moved) or
    // changes between owned and ghost.
    std::uint64_t generation() const { return generation_; }
    // Catom magnets switched off at run time (catom programs), by global id:
    // the poles switched off (bit p: pole p; kAllPolesOff: the whole catom),
    // and a counter that changes with every switch.
    static constexpr std::uint8_t kAllPolesOff = 0xFF;
    std::uint8_t poles_off(std::uint32_t gid) const { return gid < magnets_off_.size() ? magnets_off_[gid] : 0; }
    bool magnets_switched_off(std::uint32_t gid) const { return poles_off(gid) == kAllPolesOff; }
    void switch_poles(std::uint32_t gid, std::uint8_t off) {
        if (magnets_off_.size() <= gid) magnets_off_.resize(global_, 0);
        if (magnets_off_[gid] == off) return;
        magnets_off_[gid] = off;
        ++magnet_version_;
    }
    void switch_magnets(std::uint32_t gid, bool on) { switch_poles(gid, on ? 0 : kAllPolesOff); }
    std::uint64_t magnet_version() const { return magnet_version_; }
    // What the catom programs' state adds to the state hash (modulo 2^64 sum
    // of their catoms' digests on this process).
    std::uint64_t program_digest() const { return program_digest_; }
    void set_program_digest(std::uint64_t d) { program_digest_ = d; }
    // A catom program's value k (0 <= k < 4) of local body `local`, for the
    // snapshots (0 for a body without a program).
    // Sizes the values for every local body; after it, set_program_value of
    // distinct bodies may run on several threads at once.
    void size_program_values() {
        if (program_values_.size() < bodies_.size()) program_values_.resize(bodies_.size());
    }
    void set_program_value(std::size_t local, int k, double v) {
        size_program_values();
        program_values_[local][static_cast<std::size_t>(k)] = v;
    }
    double program_value(std::size_t local, int k) const {
        return local < program_values_.size() ? program_values_[local][static_cast<std::size_t>(k)] : 0.0;
    }

    // Every geom of space(): local body geoms in local order (null for a
    // ghost while ghost_geoms() is off), then statics.
    const std::vector<dGeomID>& geoms() const { return geoms_; }
    // The geom of id `id` held here (a local body's or a static one), and
    // its body (null for a static geom): what a contact's ids name.
    dGeomID geom_of(std::uint32_t id) const;
    dBodyID body_of_geom(std::uint32_t id) const;
    int material_of(std::uint32_t geom_id) const;
    // The mass of body `gid` as World gave it to ODE (dBodySetMass copies it,
    // and nothing else in parode sets a mass): what dBodyGetMass would read,
    // without touching the body's record.
    const dMass& mass_of(std::uint32_t gid) const;
    // Asks the processor for the cache lines of body `local`'s ODE record
    // that the passes over every body read and write (position, rotation,
    // quaternion, velocities, force, torque), ahead of use: the records lie
    // about 1 KB apart, so each pass over them waits on memory. The lines'
    // offsets in a record are learned once from ODE's own getters.
    void prefetch_body(std::size_t local) const {
        const char* at = reinterpret_cast<const char*>(bodies_[local]);
        for (int k = 0; k < record_lines_; ++k) __builtin_prefetch(at + record_line_[k], 1);
    }
    // The shape of a geom by id (a body's, a static geom's or a plane), from
    // the scene: no access to ODE's geom.
    enum class GeomShape { Sphere, Box, Capsule, Cylinder, Plane };
    GeomShape geom_shape(std::uint32_t geom_id) const;

    // Room for `n` bodies in every per-body array, with an eighth more for
    // the ghosts and migrants that come later: arrays grown one body at a
    // time double, and while one is copied both copies are resident.
    void reserve_bodies(std::size_t n);
    // A new body `gid` built from the scene (its initial state unless `state`
    // is given); returns its local index.
    std::size_t add_body(std::uint32_t gid, bool ghost, const BodyState* state = nullptr, const Vec3* origin = nullptr);
    // Destroys a local body; the last local body moves into its index.
    void remove_body(std::size_t local);
    void set_ghost(std::size_t local, bool ghost);
    // Whether ghosts get an ODE geom (on by default). Off, a ghost is an ODE
    // body alone (about 190 bytes less, a ninth of what a ghost costs) and
    // geoms() holds a null in its place: for a collision backend that reads
    // every body sphere from sphere_bodies() and never a geom of one
    // (CollideBackend::spheres_from_hint). Only for a scene of spheres
    // (std::logic_error otherwise); the ghosts held now follow at once.
    void set_ghost_geoms(bool on);
    bool ghost_geoms() const { return ghost_geoms_; }
    // Local bodies without a geom (ghosts while ghost_geoms() is off).
    std::size_t geomless() const { return geomless_; }
    void set_origin(std::size_t local, const Vec3& origin) { origin_[local] = origin; }
    BodyState state(std::size_t local) const;
    void set_state(std::size_t local, const BodyState& s);
    // Position and quaternion input, as the project's integrator sets them.
    void set_pose(std::size_t local, const double x[3], const double q[4]);
    // set_pose in two halves, so that the first can run on many threads:
    // write_pose leaves in ODE's body the position, quaternion and rotation
    // that dBodySetPosition and dBodySetQuaternion would (touching that body
    // only); mark_moved then tells the body's spaces, as those setters do.
    // Calling mark_moved in body order keeps each space's geom order, on
    // which ODE's own spaces' pair order depends.
    void write_pose(std::size_t local, const double x[3], const double q[4]);
    void mark_moved(std::size_t local);
    // mark_moved for every owned body, in body order. The pass is serial and
    // waits on memory (an ODE body and its geom per call), so it asks for the
    // records a few bodies ahead.
    void mark_moved_owned();
    // The owned bodies' poses were written (write_pose): mark_moved_owned now,
    // or, while moves are deferred, only a note that ODE's spaces have not
    // been told (sync_moves tells them).
    void poses_written();
    // Whether poses_written may leave the marks for later. The pipeline defers
    // them when its collision backend takes each plain sphere's AABB from the
    // sphere's position (CollideBackend::reads_sphere_poses) and every body is
    // a sphere: no reader then needs ODE's flags, and the serial pass, a
    // cache miss or two per body, is not paid every step. Turning deferral
    // off first tells the spaces of any pending moves.
    void defer_moves(bool on);
    // Tells ODE's spaces of moves not yet told; a no-op when none are pending.
    void sync_moves();
    // Every body's geom a sphere (from the scene: [[bodies]] and catoms).
    bool bodies_are_spheres() const;
    // What a collision backend may know of the body geoms without reading
    // them (collide.hpp), or null unless every body is a sphere.
    const SphereBodies* sphere_bodies() const { return spheres_.bodies ? &spheres_ : nullptr; }
    // Sets a body from a saved state; true when ODE then holds exactly the
    // quaternion `ode_q` it held when the state was saved.
    bool restore_state(std::size_t local, const BodyState& s, const double ode_q[4]);
    // After a step of ODE's own stepper: hands every body its quaternion
    // again, recording it as the input. ODE normalises what it is given, and
    // the quaternion its stepper leaves is the normalisation of an input
    // nobody knows; afterwards it is the normalisation of a recorded one, so
    // that a checkpoint can restore the body bit for bit.
    void settle_quaternions();

    // ODE's dRand state for this world: seeded from the scene; an ODE stepper
    // calls dRandSetSeed(drand_seed()) before its step and stores
    // dRandGetSeed() after it.
    unsigned long drand_seed() const { return drand_seed_; }
    void set_drand_seed(unsigned long seed) { drand_seed_ = seed; }

    // Surface parameters for a contact between two materials (mixed once, cached).
    const dSurfaceParameters& surface(int a, int b) const;
    // True for a contact between two bodies joined by a scene joint: such bodies
    // do not touch (as in ODE's own demos), for the solver and the diagnostics.
    bool ignores(const ContactRecord& c) const;
    // Create contact joints serially, in the buffer's (canonical) order, except
    // the ignored ones.
    void create_contact_joints(const ContactBuffer& contacts);
    dJointID joint(std::size_t i) const { return joints_[i]; }

private:
    void build_statics();
    // Whether two bodies are joined by a scene joint (false when either is null).
    bool joined(dBodyID b1, dBodyID b2) const;
    void build_joints();
    void build_surfaces();
    void describe_spheres();
    dGeomID make_geom(const Shape& s);
    const Shape& shape_of(std::uint32_t gid) const;  // a body's, from the scene
    void fit_geom(std::size_t local);                // the geom body `local`'s role needs (set_ghost_geoms)

    const Scene& scene_;
    std::size_t global_ = 0;
    dWorldID world_ = nullptr;
    dSpaceID space_ = nullptr;
    dJointGroupID contacts_ = nullptr;
    std::vector<dBodyID> bodies_;
    std::vector<std::uint32_t> gids_;
    std::vector<std::uint8_t> ghost_;
    std::vector<std::array<double, 4>> q_in_;
    std::vector<Vec3> origin_;
    std::vector<DomainSlot> slot_;
    std::size_t owned_ = 0;
    IdMap map_;
    std::uint64_t generation_ = 0;
    std::vector<std::uint8_t> magnets_off_;  // poles off, by global id, once a program switched one
    std::uint64_t magnet_version_ = 0;
    std::uint64_t program_digest_ = 0;
    std::vector<std::array<double, 4>> program_values_;  // per local body, once a program set one
    unsigned long drand_seed_ = 0;
    bool defer_moves_ = false;  // poses_written leaves the marks to sync_moves
    bool moves_pending_ = false;  // poses written, ODE's spaces not told
    std::vector<dGeomID> geoms_;
    bool ghost_geoms_ = true;
    std::size_t geomless_ = 0;  // null entries among geoms_'s bodies
    std::ptrdiff_t record_line_[8] = {};  // prefetch_body: cache-line offsets in a body's record
    int record_lines_ = 0;
    void learn_record_lines();
    std::vector<int> static_material_;
    std::vector<dJointID> joints_;
    std::vector<dSurfaceParameters> surfaces_;  // materials x materials
    std::vector<dMass> body_mass_;  // per scene body (scene.bodies)
    dMass catom_mass_{};            // every catom's
    SphereBodies spheres_;          // bodies null unless bodies_are_spheres()
};

}  // namespace parode
