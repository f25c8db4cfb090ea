// Catom prism and magnet layout generators (see generators.hpp).
#include "scene/generators.hpp"

#include <algorithm>
#include <cmath>

#include "scene/limits.hpp"
#include "scene/scene_keys.hpp"

namespace parode {

void prism_dims(long count, long dims[3]) {
    long side = static_cast<long>(std::ceil(std::cbrt(static_cast<double>(count)) - 1e-9));
    side = std::max(side, 1L);
    dims[0] = side;
    dims[1] = side;
    dims[2] = (count + side * side - 1) / (side * side);
}

namespace {

int catom_material(const Node& t, const Scene& sc) {
    if (!t.has("material")) return 0;
    const std::string m = t.string("material", "");
    std::string list;
    for (std::size_t i = 0; i < sc.materials.size(); ++i) {
        if (sc.materials[i].name == m) return static_cast<int>(i);
        list += (list.empty() ? "" : ", ") + sc.materials[i].name;
    }
    t.fail("material", "the name of a material (" + list + ")");
}

}  // namespace

namespace {

// [magnets] enabled and strength, as read_magnets and plan_catoms both need them.
struct MagnetSwitch {
    bool enabled = true;
    double strength = MagnetModel{}.strength;
};
MagnetSwitch magnet_switch(const Node& t) {
    MagnetSwitch m;
    m.enabled = t.boolean("enabled", m.enabled);
    m.strength = t.number("strength", m.strength, 0.0);
    return m;
}

}  // namespace

CatomPlan plan_catoms(const Node& root) {
    CatomPlan p;
    p.program = root.has("program");
    if (!root.has("catoms")) return p;
    const Node t = root.at("catoms");
    t.require_table();
    p.count = t.integer("count", 1000, 1, 100000000);
    p.radius = t.number("radius", 0.5, limits::kMinSize, limits::kMaxSize);
    p.spacing = t.number("spacing", 2 * p.radius, p.radius, limits::kMaxSize);  // overlap at most one radius
    if (root.has("magnets")) {
        const Node m = root.at("magnets");
        m.require_table();
        const MagnetSwitch s = magnet_switch(m);
        p.magnets = s.enabled && s.strength != 0;
    }
    return p;
}

void read_catoms(const Node& root, const CatomPlan& plan, Scene& sc) {
    if (!root.has("catoms")) return;
    const Node t = root.at("catoms");
    t.expect_keys(table_keys("catoms"));
    t.choice("layout", "prism", {"prism"});
    BodySpec proto;
    proto.catom = true;
    proto.shape.kind = ShapeKind::Sphere;
    proto.shape.radius = plan.radius;
    proto.mass = t.number("mass", 1.0, limits::kMinMass, limits::kMaxMass);
    proto.material = catom_material(t, sc);
    proto.velocity = t.vec3_length("velocity", proto.velocity, limits::max_speed(sc.dt), limits::speed_text(sc.dt));
    const double r = proto.shape.radius;
    CatomBlock& c = sc.catoms;
    c.first = sc.bodies.size();
    c.count = static_cast<std::size_t>(plan.count);
    c.spacing = plan.spacing;
    c.jitter = t.number("jitter", 0.01, 0.0, 1.0) * r;
    c.base = t.vec3("base", Vec3{0, 0, 0}, limits::kMaxCoordinate, limits::coordinate_text());
    prism_dims(plan.count, c.dims);
    c.seed = sc.seed;
    c.proto = proto;
}

namespace {

void layout_axes6(MagnetModel& m) {
    m.directions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    m.charges = {1, -1, 1, -1, 1, -1};  // facing poles of lattice neighbours attract
}

void layout_cube8(MagnetModel& m) {
    const double s = 1 / std::sqrt(3.0);
    m.directions.clear();
    m.charges.clear();
    for (int k = 0; k < 8; ++k) {
        const double x = (k & 1) ? s : -s, y = (k & 2) ? s : -s, z = (k & 4) ? s : -s;
        m.directions.push_back({x, y, z});
        m.charges.push_back((((k & 1) + ((k >> 1) & 1) + ((k >> 2) & 1)) % 2) ? 1 : -1);
    }
}

// "catoms are bodies 1 to 8": generated catoms are contiguous, after the [[bodies]].
std::string catom_range(const Scene& sc) {
    long first = -1, last = -1;
    for (std::size_t i = 0; i < sc.bodies.size(); ++i) {
        if (!sc.bodies[i].catom) continue;
        if (first < 0) first = static_cast<long>(i);
        last = static_cast<long>(i);
    }
    if (sc.catoms.count > 0) {
        if (first < 0) first = static_cast<long>(sc.catoms.first);
        last = static_cast<long>(sc.catoms.first + sc.catoms.count - 1);
    }
    if (first < 0) return "this scene has no catoms";
    return "catoms are bodies " + std::to_string(first) + " to " + std::to_string(last);
}

void read_magnets_off(const Node& off, Scene& sc) {
    for (std::size_t i = 0; i < off.array_size(); ++i) {
        const toml::value& v = off.value().as_array()[i];
        const long n = v.is_integer() ? static_cast<long>(v.as_integer()) : -1;
        const bool listed = n >= 0 && n < static_cast<long>(sc.bodies.size()) && sc.bodies[n].catom;
        const bool generated = n >= static_cast<long>(sc.catoms.first) && n < static_cast<long>(sc.body_count());
        if (!listed && !generated) {
            throw SceneError(where(v) + ": key '" + off.index(i).path() + "': expected the id of a catom body (" +
                             catom_range(sc) + "), got " + describe(v));
        }
        if (listed) sc.bodies[n].magnets = false;
        else sc.magnets_off.push_back(static_cast<std::uint32_t>(n));
    }
    std::sort(sc.magnets_off.begin(), sc.magnets_off.end());
    sc.magnets_off.erase(std::unique(sc.magnets_off.begin(), sc.magnets_off.end()), sc.magnets_off.end());
}

}  // namespace

void read_magnets(const Node& root, Scene& sc) {
    if (!root.has("magnets")) return;
    const Node t = root.at("magnets");
    t.expect_keys(table_keys("magnets"));
    MagnetModel& m = sc.magnets;
    const MagnetSwitch s = magnet_switch(t);
    m.enabled = s.enabled;
    const std::string layout = t.choice("layout", "axes6", {"axes6", "cube8"});
    if (layout == "axes6") layout_axes6(m);
    else layout_cube8(m);
    m.strength = s.strength;
    m.softening = t.number("softening", m.softening, 1e-9);
    m.cutoff = t.number("cutoff", m.cutoff, 1e-9);
    for (auto& b : sc.bodies) b.magnets = b.catom && m.enabled;
    sc.catoms.proto.magnets = m.enabled;
    if (t.has("off")) read_magnets_off(t.at("off"), sc);
}

}  // namespace parode
