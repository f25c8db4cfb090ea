// Random and lattice test scenes (see random_scene.hpp).
// Trade-off: a local splitmix64 generator instead of <random> distributions, so
// a seed gives the same scene with every standard library.
#include "random_scene.hpp"

#include <cmath>

#include "collide/contacts.hpp"

namespace parode::test {
namespace {

std::uint64_t splitmix(std::uint64_t& s) {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

}  // namespace

double RandomScene::uniform(double lo, double hi) {
    const double u = static_cast<double>(splitmix(state_) >> 11) * (1.0 / 9007199254740992.0);
    return lo + (hi - lo) * u;
}

RandomScene::RandomScene(std::uint32_t seed, const SceneOptions& opt)
    : state_(seed * 7919ull + 17), opt_(opt) {
    world_ = dWorldCreate();
    space_ = dHashSpaceCreate(nullptr);
    for (int i = 0; i < opt.geoms; ++i) {
        const int kind = static_cast<int>(uniform(0, 4));
        dGeomID g = add_shape(space_, kind, uniform(0.2, 0.8));
        place(g, uniform(0, 1) < 0.8);
        if (opt.special) apply_specials(g);
    }
    if (opt.planes) {
        geoms_.push_back(dCreatePlane(space_, 0, 0, 1, 0.3));
        geoms_.push_back(dCreatePlane(space_, 1, 0, 0, -1.0));
        const double s = 1.0 / std::sqrt(3.0);
        geoms_.push_back(dCreatePlane(space_, s, s, s, 1.5));
    }
    if (opt.special) {
        dGeomID zero = dCreateSphere(space_, 0);
        dGeomSetPosition(zero, 1, 1, 1);
        geoms_.push_back(zero);
        dGeomID big = dCreateBox(space_, 40, 3, 2);  // far above the typical size
        dGeomSetPosition(big, opt.extent / 2, opt.extent / 2, opt.extent / 3);
        geoms_.push_back(big);
    }
    if (opt.trimesh) add_trimesh();
    if (opt.nested > 0) {
        nested_ = dSimpleSpaceCreate(space_);
        for (int i = 0; i < opt.nested; ++i) {
            dGeomID g = add_shape(nested_, static_cast<int>(uniform(0, 4)), uniform(0.2, 0.6));
            place(g, uniform(0, 1) < 0.7);
            if (opt.special) apply_specials(g);
        }
    }
    for (std::size_t i = 0; i < geoms_.size(); ++i) set_geom_id(geoms_[i], static_cast<std::uint32_t>(i));
}

RandomScene::~RandomScene() {
    dSpaceDestroy(space_);  // destroys the nested space and all geoms
    if (mesh_data_) dGeomTriMeshDataDestroy(mesh_data_);
    dWorldDestroy(world_);
}

// A square sheet of two triangles across the scene, tilted a little.
void RandomScene::add_trimesh() {
    const double e = opt_.extent;
    const double z = 0.4 * e;
    mesh_vertices_ = {0, 0, z, 0, e, 0, z + 0.5, 0, 0, e, z - 0.3, 0, e, e, z + 0.2, 0};
    mesh_indices_ = {0, 1, 2, 1, 3, 2};
    mesh_data_ = dGeomTriMeshDataCreate();
    dGeomTriMeshDataBuildDouble(mesh_data_, mesh_vertices_.data(), 4 * sizeof(dReal), 4,
                                mesh_indices_.data(), 6, 3 * sizeof(dTriIndex));
    geoms_.push_back(dCreateTriMesh(space_, mesh_data_, nullptr, nullptr, nullptr));
}

dGeomID RandomScene::add_shape(dSpaceID space, int kind, double size) {
    dGeomID g = nullptr;
    switch (kind) {
        case 0: g = dCreateSphere(space, size); break;
        case 1: g = dCreateBox(space, size * 1.5, size, size * 0.7); break;
        case 2: g = dCreateCapsule(space, size * 0.5, size * 1.2); break;
        default: g = dCreateCylinder(space, size * 0.5, size * 1.3); break;
    }
    geoms_.push_back(g);
    return g;
}

// Either a new body (sometimes shared by the next geoms, through offsets), or
// a static geom with its own pose.
void RandomScene::place(dGeomID g, bool own_body) {
    const double e = opt_.extent;
    dMatrix3 R;
    dRFromEulerAngles(R, uniform(0, 3), uniform(0, 3), uniform(0, 3));
    if (!own_body) {
        dGeomSetPosition(g, uniform(0, e), uniform(0, e), uniform(0, e));
        dGeomSetRotation(g, R);
        return;
    }
    if (!bodies_.empty() && uniform(0, 1) < 0.25) {
        dGeomSetBody(g, bodies_.back());  // same body as the previous geom
        dGeomSetOffsetPosition(g, uniform(-0.3, 0.3), uniform(-0.3, 0.3), uniform(-0.3, 0.3));
        dGeomSetOffsetRotation(g, R);
        return;
    }
    dBodyID b = dBodyCreate(world_);
    dBodySetPosition(b, uniform(0, e), uniform(0, e), uniform(0, e));
    dBodySetRotation(b, R);
    if (opt_.special && uniform(0, 1) < 0.2) dBodyDisable(b);
    bodies_.push_back(b);
    dGeomSetBody(g, b);
}

void RandomScene::apply_specials(dGeomID g) {
    const double u = uniform(0, 1);
    if (u < 0.08) dGeomDisable(g);
    if (uniform(0, 1) < 0.2) {
        // Bit 40 is beyond what the collider's flags hold (kWideBits); 0xff
        // has the low byte of all ones, which the flags also stand for.
        const unsigned long mask[5] = {1ul, 2ul, 4ul, 1ul << 40, 0xfful};
        dGeomSetCategoryBits(g, mask[static_cast<int>(uniform(0, 4.999))]);
        dGeomSetCollideBits(g, mask[static_cast<int>(uniform(0, 4.999))]);
    }
}

SpherePrism::SpherePrism(int n, double r, double jitter, std::uint32_t seed, int space_class) {
    world_ = dWorldCreate();
    if (space_class == dHashSpaceClass) {
        space_ = dHashSpaceCreate(nullptr);
    } else if (space_class == dSweepAndPruneSpaceClass) {
        space_ = dSweepAndPruneSpaceCreate(nullptr, dSAP_AXES_XZY);
    } else {
        space_ = dSimpleSpaceCreate(nullptr);
    }
    std::uint64_t s = seed * 1000003ull + 1;
    auto jit = [&] {
        const double u = static_cast<double>(splitmix(s) >> 11) * (1.0 / 9007199254740992.0);
        return (2 * u - 1) * jitter * r;
    };
    std::uint32_t id = 0;
    dGeomID plane = dCreatePlane(space_, 0, 0, 1, 0);
    set_geom_id(plane, id++);
    for (int k = 0; k < n; ++k) {
        for (int j = 0; j < n; ++j) {
            for (int i = 0; i < n; ++i) {
                dBodyID b = dBodyCreate(world_);
                dBodySetPosition(b, 2 * r * i + jit(), 2 * r * j + jit(), r + 2 * r * k + jit());
                dGeomID g = dCreateSphere(space_, r);
                dGeomSetBody(g, b);
                set_geom_id(g, id++);
            }
        }
    }
}

SpherePrism::~SpherePrism() {
    dSpaceDestroy(space_);
    dWorldDestroy(world_);
}

}  // namespace parode::test
