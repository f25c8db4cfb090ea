// World: the ODE world, one space, bodies, geoms and joints built from a Scene,
// with a stable global id for every body and geom (geom id = body id for bodies;
// statics and planes follow). ODE's dRand is seeded from the scene at creation.
// Dynamic geoms are category 1, static geoms category 2 and collide only with
// dynamic ones, so static-static pairs are never tested.
// Trade-off: one geom per body keeps ids trivial; compound bodies would need a
// geom -> body table (geom_body() already exists for that).
#pragma once
#include <ode/ode.h>

#include <vector>

#include "collide/collide.hpp"
#include "scene/scene.hpp"

namespace parode {

// ODE's global initialisation, once per process.
void ensure_ode_initialised();

class World {
public:
    World(const Scene& scene, SpaceKind space_kind);
    ~World();
    World(const World&) = delete;
    World& operator=(const World&) = delete;

    const Scene& scene() const { return scene_; }
    dWorldID id() const { return world_; }
    dSpaceID space() const { return space_; }
    dJointGroupID contact_group() const { return contacts_; }

    std::size_t body_count() const { return bodies_.size(); }
    dBodyID body(std::size_t i) const { return bodies_[i]; }
    const std::vector<dBodyID>& bodies() const { return bodies_; }
    std::size_t geom_count() const { return geoms_.size(); }
    dGeomID geom(std::size_t i) const { return geoms_[i]; }
    const std::vector<dGeomID>& geoms() const { return geoms_; }  // every geom of space(), by id
    int geom_material(std::size_t i) const { return geom_material_[i]; }
    dJointID joint(std::size_t i) const { return joints_[i]; }

    // Surface parameters for a contact between two materials (mixed once, cached).
    const dSurfaceParameters& surface(int a, int b) const;
    // True for a contact between two bodies joined by a scene joint: such bodies
    // do not touch (as in ODE's own demos), for the solver and the diagnostics.
    bool ignores(const ContactRecord& c) const;
    // Create contact joints serially, in the buffer's (canonical) order, except
    // the ignored ones.
    void create_contact_joints(const std::vector<ContactRecord>& contacts);

private:
    void build_bodies();
    void build_statics();
    void build_joints();
    void build_surfaces();
    dGeomID make_geom(const Shape& s);

    const Scene& scene_;
    dWorldID world_ = nullptr;
    dSpaceID space_ = nullptr;
    dJointGroupID contacts_ = nullptr;
    std::vector<dBodyID> bodies_;
    std::vector<dGeomID> geoms_;
    std::vector<int> geom_material_;
    std::vector<dJointID> joints_;
    std::vector<dSurfaceParameters> surfaces_;  // materials x materials
};

}  // namespace parode
