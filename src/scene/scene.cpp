// Scene queries (see scene.hpp).
#include "scene/scene.hpp"

#include <algorithm>
#include <cmath>

#include "util/split_mix.hpp"

namespace parode {

Vec3 CatomBlock::position(std::size_t n) const {
    const long i = static_cast<long>(n) % dims[0], j = (static_cast<long>(n) / dims[0]) % dims[1];
    const long k = static_cast<long>(n) / (dims[0] * dims[1]);
    const double r = proto.shape.radius;
    Vec3 p{base[0] + (i - 0.5 * (dims[0] - 1)) * spacing, base[1] + (j - 0.5 * (dims[1] - 1)) * spacing,
           base[2] + r + k * spacing};
    for (int a = 0; a < 3; ++a) p[a] += (2 * SplitMix64::uniform_at(seed, 3 * n + a) - 1) * jitter;
    return p;
}

BodySpec Scene::body(std::size_t gid) const {
    if (gid < bodies.size()) return bodies[gid];
    BodySpec b = catoms.proto;
    b.position = catoms.position(gid - catoms.first);
    b.magnets = body_magnets(gid);
    return b;
}

bool Scene::body_magnets(std::size_t gid) const {
    if (gid < bodies.size()) return bodies[gid].magnets;
    return catoms.proto.magnets &&
           !std::binary_search(magnets_off.begin(), magnets_off.end(), static_cast<std::uint32_t>(gid));
}

double bounding_radius(const Shape& sh) {
    switch (sh.kind) {
        case ShapeKind::Sphere: return sh.radius;
        case ShapeKind::Box: return 0.5 * std::sqrt(sh.size[0] * sh.size[0] + sh.size[1] * sh.size[1] + sh.size[2] * sh.size[2]);
        case ShapeKind::Capsule:
        case ShapeKind::Cylinder: break;
    }
    return sh.radius + 0.5 * sh.length;
}

double Scene::max_bounding_radius() const {
    double r = catoms.count ? bounding_radius(catoms.proto.shape) : 0.0;
    for (const BodySpec& b : bodies) r = std::max(r, bounding_radius(b.shape));
    return r;
}

double Scene::program_reach() const {
    if (program.reach >= 0) return program.reach;
    if (magnets.enabled) return magnets.cutoff;
    for (const BodySpec& b : bodies) {
        if (b.catom) return 0.1 * b.shape.radius;  // the first catom's
    }
    return catoms.count ? 0.1 * catoms.proto.shape.radius : 0.0;
}

double Scene::program_range() const {
    double rmax = 0;
    for (const BodySpec& b : bodies) {
        if (b.catom) rmax = std::max(rmax, b.shape.radius);
    }
    if (catoms.count) rmax = std::max(rmax, catoms.proto.shape.radius);
    return 2 * rmax + program_reach();
}

std::size_t Scene::catom_count() const {
    std::size_t n = catoms.count;
    for (const auto& b : bodies) n += b.catom ? 1 : 0;
    return n;
}

std::size_t Scene::magnet_count() const {
    std::size_t n = catoms.proto.magnets ? catoms.count - magnets_off.size() : 0;
    for (const auto& b : bodies) n += b.magnets ? 1 : 0;
    return n;
}

bool Scene::any_magnets() const { return magnets.enabled && magnets.strength != 0 && magnet_count() > 0; }

int Scene::find_body(const std::string& n) const {
    for (std::size_t i = 0; i < bodies.size(); ++i) if (!n.empty() && bodies[i].name == n) return static_cast<int>(i);
    return -1;
}

bool CheckSpec::any() const {
    return max_penetration || max_final_penetration || max_energy_gain || max_displacement || max_final_speed || min_disabled ||
           max_escaped || !positions.empty();
}

int Scene::find_joint(const std::string& n) const {
    for (std::size_t i = 0; i < joints.size(); ++i) if (joints[i].name == n) return static_cast<int>(i);
    return -1;
}

nlohmann::json solver_json(const SolverSpec& s) {
    return {{"stepper", s.stepper == Stepper::Quick ? "quick" : "world"}, {"iterations", s.iterations},
            {"sor_w", s.sor_w}, {"erp", s.erp}, {"cfm", s.cfm}, {"substeps", s.substeps},
            {"adaptive_sweeps", s.adaptive_sweeps}, {"tolerance", s.tolerance}, {"extra_sweeps", s.extra_sweeps}};
}

}  // namespace parode
