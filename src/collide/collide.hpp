// The collide stage's interface and the reference backends built on ODE's spaces.
// A backend fills a ContactBuffer with every contact of a space, in canonical
// order. The references (ode-hash, ode-sap, ode-simple) run ODE's own serial
// dSpaceCollide with a near-callback that only collects contacts; the grid
// backends live in omp/ and omp::add_stages adds them to the stage registry.
// Trade-off: the reference sorts contacts after collection, which costs a little
// but makes every backend's output directly comparable, bit for bit.
#pragma once
#include <ode/ode.h>

#include <functional>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "collide/contacts.hpp"
#include "exec/execution.hpp"
#include "util/registry.hpp"
#include "util/substages.hpp"

namespace parode {

// A hint beside CollideBackend::set_geoms, for a flat space whose first geoms
// belong one to a body, in body order (World's): geom i < bodies->size() is
// an enabled sphere without offset on body (*bodies)[i], with id (*ids)[i],
// radius radius(id), and the bits category[g], collide[g] with g = (*ghost)[i].
// A backend may then read such a geom's body position alone from ODE. The
// vectors are the owner's and must outlive the hint; their contents may change
// between calls (bodies added, removed, turned into ghosts). *geomless of the
// geoms below bodies->size() may be null (ghosts without a geom,
// World::set_ghost_geoms) and are then not in the space: only a backend whose
// spheres_from_hint() is true may be given such a list.
struct SphereBodies {
    const std::vector<dBodyID>* bodies = nullptr;
    const std::vector<std::uint32_t>* ids = nullptr;
    const std::vector<std::uint8_t>* ghost = nullptr;
    std::vector<double> body_radius;  // ids below its size
    double catom_radius = 0;          // every other id
    unsigned long category[2] = {0, 0}, collide[2] = {0, 0};
    const std::size_t* geomless = nullptr;  // null geoms among the bodies' (none when null)
    std::size_t missing() const { return geomless ? *geomless : 0; }
    double radius(std::uint32_t id) const { return id < body_radius.size() ? body_radius[id] : catom_radius; }
};

// Which contacts a process of a distributed run leaves to another: those whose
// lower id (lo) is a body it holds as a ghost (that body's owner computes
// them). Ids from `bodies` on are static geoms, never ghosts.
struct GhostTest {
    const void* context = nullptr;
    bool (*ghost)(const void* context, std::uint32_t id) = nullptr;  // id < bodies, a geom held here
    std::uint32_t bodies = 0;
    bool drops(std::uint32_t lo) const { return lo < bodies && ghost(context, lo); }
};

// Removes from `out` the contacts `test` drops, keeping the others' order.
void drop_ghost_contacts(ContactBuffer& out, const GhostTest& test);

// Which ODE space a backend wants World to build the scene into.
enum class SpaceKind { Hash, SweepAndPrune, Simple };

class CollideBackend {
public:
    virtual ~CollideBackend() = default;
    virtual std::string name() const = 0;
    virtual SpaceKind space_kind() const = 0;
    // Every contact between geoms of `space` (recursing into nested spaces), in
    // canonical order. `max_contacts` bounds the contacts of one pair.
    virtual void collide(dSpaceID space, int max_contacts, ContactBuffer& out) = 0;
    // A hint: `space` holds exactly these geoms and no nested space (World's
    // flat space), so a backend may read them without walking ODE's list.
    // The pointer must stay valid while the backend collides that space.
    virtual void set_geoms(dSpaceID /*space*/, const std::vector<dGeomID>* /*geoms*/) {}
    // A further hint on those geoms (SphereBodies above), or null to forget it.
    virtual void set_sphere_bodies(const SphereBodies* /*spheres*/) {}
    // Seconds spent in the backend's substages so far, or null.
    virtual const Substages* substages() const { return nullptr; }
    // Counts the backend keeps over the run (name, count), for the run report;
    // every process of a run gives the same names in the same order.
    virtual std::vector<std::pair<std::string, std::int64_t>> counts() const { return {}; }
    // True when the backend takes a sphere's AABB (no offset) from its current
    // position and radius, never from ODE's cached AABB: sphere bodies may
    // then move without ODE's spaces being told every step (World::defer_moves).
    virtual bool reads_sphere_poses() const { return false; }
    // True when, given set_geoms and set_sphere_bodies, the backend reads
    // every body sphere of that space from the hint alone and never touches
    // a body geom's record: a ghost then needs no ODE geom at all
    // (World::set_ghost_geoms).
    virtual bool spheres_from_hint() const { return false; }
    // Asks the backend to leave out of collide()'s output the contacts `test`
    // drops (null: none), before it writes them; false when it cannot, and
    // the caller then removes them from the output itself.
    virtual bool set_ghost_test(const GhostTest* /*test*/) { return false; }
};

// Name -> factory, in the stage registry (run/stages.hpp). A backend takes
// its threads, crossovers and scratch pool from the pipeline's execution.
using CollideRegistry = Registry<CollideBackend, Execution&>;
// Adds the references: ode-hash, ode-sap, ode-simple.
void add_reference_backends(CollideRegistry& registry);

// Reference collision through ODE's own dSpaceCollide (exposed for tests).
void collide_space_reference(dSpaceID space, int max_contacts, ContactBuffer& out);

// One geom (or space) against a space, the serial reference of collide2.
void collide2_reference(dGeomID geom, dSpaceID space, int max_contacts, ContactBuffer& out);

}  // namespace parode
