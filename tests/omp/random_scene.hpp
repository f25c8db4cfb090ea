// Seeded random scenes for the collision tests: mixed primitives (spheres,
// boxes, capsules, cylinders, planes, a zero-sized sphere, an oversized box,
// a trimesh sheet),
// shared bodies (same-body pairs, offset geoms), disabled bodies, disabled
// geoms, custom category/collide bits and a nested space, all in an ODE hash
// space so ODE's own dSpaceCollide is the reference. Also the touching sphere
// prism of the performance targets.
// Trade-off: dense on purpose (many overlaps per geom) so that small scenes
// exercise every filter, at the cost of not looking like a physical pile.
#pragma once
#include <ode/ode.h>

#include <cstdint>
#include <vector>

namespace parode::test {

struct SceneOptions {
    int geoms = 300;          // top-level geoms (planes and the nested space extra)
    int nested = 40;          // geoms in the nested space (0: none)
    double extent = 6.0;      // side of the cube the geoms are placed in
    bool planes = true;
    bool special = true;      // bits, disabled geoms/bodies, zero-size, big box
    bool trimesh = true;      // a two-triangle trimesh sheet (serial pairs)
};

// Owns an ODE world and a hash space with a random scene; geoms have ids 0..n-1.
class RandomScene {
public:
    RandomScene(std::uint32_t seed, const SceneOptions& opt);
    ~RandomScene();
    RandomScene(const RandomScene&) = delete;
    RandomScene& operator=(const RandomScene&) = delete;

    dSpaceID space() const { return space_; }
    dSpaceID nested() const { return nested_; }
    const std::vector<dGeomID>& geoms() const { return geoms_; }
    dWorldID world() const { return world_; }

private:
    dGeomID add_shape(dSpaceID space, int kind, double size);
    void place(dGeomID g, bool own_body);
    void apply_specials(dGeomID g);
    void add_trimesh();
    double uniform(double lo, double hi);

    dWorldID world_ = nullptr;
    dSpaceID space_ = nullptr;
    dSpaceID nested_ = nullptr;
    std::vector<dGeomID> geoms_;
    std::vector<dBodyID> bodies_;
    std::vector<dReal> mesh_vertices_;
    std::vector<dTriIndex> mesh_indices_;
    dTriMeshDataID mesh_data_ = nullptr;
    std::uint64_t state_;
    SceneOptions opt_;
};

// n x n x n spheres of radius r touching in a prism (spacing 2r), each centre
// jittered by `jitter * r`, over the plane z = 0; one body per sphere.
class SpherePrism {
public:
    SpherePrism(int n, double r, double jitter, std::uint32_t seed, int space_class);
    ~SpherePrism();
    SpherePrism(const SpherePrism&) = delete;
    SpherePrism& operator=(const SpherePrism&) = delete;
    dSpaceID space() const { return space_; }

private:
    dWorldID world_ = nullptr;
    dSpaceID space_ = nullptr;
};

}  // namespace parode::test
