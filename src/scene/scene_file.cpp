// Scene file schema: each table of the TOML file has one reader function that
// checks its keys and fills the Scene (see README "Scene file reference").
// Trade-off: names (materials, bodies, joints) are resolved to indices once,
// here, so later stages never look anything up by string.
#include "scene/scene_file.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "scene/generators.hpp"
#include "scene/limits.hpp"
#include "scene/scene_checks.hpp"
#include "scene/scene_keys.hpp"
#include "util/hash.hpp"

namespace parode {
namespace {

// `t.key` scaled to length 1; scaling by the largest component first keeps
// 1e300 or 1e-300 components from overflowing the squares.
Vec3 unit_vector(const Node& t, const std::string& key, const Vec3& def) {
    Vec3 v = t.vec3(key, def);
    const double m = std::max({std::fabs(v[0]), std::fabs(v[1]), std::fabs(v[2])});
    if (m == 0) t.fail(key, "a non-zero vector");
    for (double& c : v) c /= m;
    const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (double& c : v) c /= n;
    return v;
}

// Unit vectors less than 1e-6 rad apart (or opposite).
bool parallel(const Vec3& a, const Vec3& b) {
    const Vec3 c{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    return std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) < 1e-6;
}

// `table`: "[[bodies]]" or "[[statics]]", whose rotation keys apply.
Quat read_rotation(const Node& t, const std::string& table) {
    if (!t.has("rotation")) return Quat{1, 0, 0, 0};
    const Node r = t.at("rotation");
    r.expect_keys(table_keys(table + ".rotation"));
    const Vec3 axis = unit_vector(r, "axis", Vec3{0, 0, 1});
    const double angle = r.number_required("angle");
    const double s = std::sin(angle / 2);
    return Quat{std::cos(angle / 2), axis[0] * s, axis[1] * s, axis[2] * s};
}

// A joint axis: ODE normalises it, but cannot normalise a zero vector.
Vec3 joint_axis(const Node& t, const std::string& key, const Vec3& def) {
    const Vec3 v = t.vec3(key, def);
    if (v[0] == 0 && v[1] == 0 && v[2] == 0) t.fail(key, "a non-zero vector");
    return v;
}

Shape read_shape(const Node& t) {
    Shape s;
    const std::string kind = t.choice("shape", "sphere", {"sphere", "box", "capsule", "cylinder"});
    if (kind == "box") {
        s.kind = ShapeKind::Box;
        s.size = t.vec3("size", Vec3{1, 1, 1});
        for (double x : s.size) {
            if (!(x >= limits::kMinSize && x <= limits::kMaxSize)) t.fail("size", "three numbers in [0.0001, 10000] (m)");
        }
        return s;
    }
    s.kind = kind == "sphere" ? ShapeKind::Sphere : kind == "capsule" ? ShapeKind::Capsule : ShapeKind::Cylinder;
    s.radius = t.number("radius", 0.5, limits::kMinSize, limits::kMaxSize);
    if (s.kind != ShapeKind::Sphere) s.length = t.number("length", 1.0, limits::kMinSize, limits::kMaxSize);
    return s;
}

int material_index(const Scene& sc, const Node& t, const std::string& key) {
    const std::string name = t.string(key, sc.materials.front().name);
    for (std::size_t i = 0; i < sc.materials.size(); ++i) {
        if (sc.materials[i].name == name) return static_cast<int>(i);
    }
    std::string list;
    for (const auto& m : sc.materials) list += (list.empty() ? "" : ", ") + m.name;
    t.fail(key, "the name of a material (" + list + ")");
}

void read_scene_table(const Node& root, Scene& sc) {
    const Node t = root.at("scene");
    t.expect_keys(table_keys("scene"));
    sc.name = t.string("name", "");
    if (sc.name.empty()) t.fail("name", "a non-empty string");
    sc.seed = static_cast<std::uint64_t>(t.integer("seed", 1, 0, std::numeric_limits<long>::max()));
    sc.steps = static_cast<int>(t.integer("steps", 1000, 0, 1000000000));
    sc.dt = t.number("dt", 0.005, 1e-9, 1.0);
    sc.gravity = t.vec3_length("gravity", Vec3{0, 0, -9.81}, limits::kMaxGravity,
                               "an array of 3 numbers of length <= 1000 (m/s^2)");
    sc.observe_every = static_cast<int>(t.integer("observe_every", 10, 1, 1000000000));
}

void read_solver(const Node& root, SolverSpec& s) {
    if (!root.has("solver")) return;
    const Node t = root.at("solver");
    t.expect_keys(table_keys("solver"));
    s.stepper = t.choice("stepper", "quick", {"quick", "world"}) == "quick" ? Stepper::Quick : Stepper::World;
    s.iterations = static_cast<int>(t.integer("iterations", s.iterations, 1, 100000));
    s.sor_w = t.number("sor_w", s.sor_w, 0.01, 2.0);
    s.erp = t.number("erp", s.erp, 0.0, 1.0);
    s.cfm = t.number("cfm", s.cfm, 0.0, 1.0);
    s.contact_surface_layer = t.number("contact_surface_layer", s.contact_surface_layer, 0.0);
    s.contact_max_correcting_vel = t.number("contact_max_correcting_vel", s.contact_max_correcting_vel, 0.0);
    s.max_contacts = static_cast<int>(t.integer("max_contacts", s.max_contacts, 1, 64));
    s.warm_start = t.boolean("warm_start", s.warm_start);
    s.substeps = static_cast<int>(t.integer("substeps", s.substeps, 1, 64));
    s.adaptive_sweeps = static_cast<int>(t.integer("adaptive_sweeps", s.adaptive_sweeps, 1, 100000));
    s.tolerance = t.number("tolerance", s.tolerance, 0.0);
    s.extra_sweeps = static_cast<int>(t.integer("extra_sweeps", s.extra_sweeps, 0, 100000));
    if (!t.has("auto_disable")) return;
    const Node a = t.at("auto_disable");
    a.expect_keys(table_keys("solver.auto_disable"));
    s.auto_disable = a.boolean("enabled", true);
    s.auto_disable_linear = a.number("linear", s.auto_disable_linear, 0.0);
    s.auto_disable_angular = a.number("angular", s.auto_disable_angular, 0.0);
    s.auto_disable_steps = static_cast<int>(a.integer("steps", s.auto_disable_steps, 1, 1000000));
}

void read_materials(const Node& root, Scene& sc) {
    if (!root.has("materials")) {
        sc.materials.push_back(Material{"default"});
        return;
    }
    const Node arr = root.at("materials");
    const std::vector<std::string> keys = table_keys("[[materials]]");
    for (std::size_t i = 0; i < arr.array_size(); ++i) {
        const Node t = arr.index(i);
        t.expect_keys(keys);
        Material m;
        m.name = t.string("name", "");
        if (m.name.empty()) t.fail("name", "a non-empty string");
        for (const auto& o : sc.materials) if (o.name == m.name) t.fail("name", "a name not used by another material");
        m.mu = t.number("mu", m.mu, 0.0);
        m.bounce = t.number("bounce", m.bounce, 0.0, 1.0);
        m.bounce_vel = t.number("bounce_vel", m.bounce_vel, 0.0);
        m.soft_erp = t.number("soft_erp", m.soft_erp, 0.0, 1.0);
        m.soft_cfm = t.number("soft_cfm", m.soft_cfm, 0.0);
        m.slip = t.number("slip", m.slip, 0.0);
        sc.materials.push_back(m);
    }
    if (sc.materials.empty()) arr.fail_here("key 'materials': expected at least one material");
}

void read_bodies(const Node& root, Scene& sc) {
    if (!root.has("bodies")) return;
    const Node arr = root.at("bodies");
    const std::vector<std::string> keys = table_keys("[[bodies]]");
    for (std::size_t i = 0; i < arr.array_size(); ++i) {
        const Node t = arr.index(i);
        t.expect_keys(keys);
        BodySpec b;
        b.name = t.string("name", "");
        if (b.name.empty()) t.fail("name", "a non-empty string");
        if (sc.find_body(b.name) >= 0) t.fail("name", "a name not used by another body");
        b.shape = read_shape(t);
        b.mass = t.number("mass", 1.0, limits::kMinMass, limits::kMaxMass);
        b.position = t.vec3("position", b.position, limits::kMaxCoordinate, limits::coordinate_text());
        b.orientation = read_rotation(t, "[[bodies]]");
        b.velocity = t.vec3_length("velocity", b.velocity, limits::max_speed(sc.dt), limits::speed_text(sc.dt));
        b.angular_velocity = t.vec3_length("angular_velocity", b.angular_velocity, limits::max_turn_rate(sc.dt),
                                           limits::turn_rate_text(sc.dt));
        b.material = material_index(sc, t, "material");
        b.catom = t.boolean("catom", false);
        if (b.catom && b.shape.kind != ShapeKind::Sphere) t.fail("catom", "false for a shape other than a sphere");
        sc.bodies.push_back(b);
    }
}

void read_statics(const Node& root, Scene& sc) {
    if (!root.has("statics")) return;
    const Node arr = root.at("statics");
    const std::vector<std::string> keys = table_keys("[[statics]]");
    for (std::size_t i = 0; i < arr.array_size(); ++i) {
        const Node t = arr.index(i);
        t.expect_keys(keys);
        StaticGeom g;
        g.name = t.string("name", "static" + std::to_string(i));
        g.shape = read_shape(t);
        g.position = t.vec3("position", g.position, limits::kMaxCoordinate, limits::coordinate_text());
        g.orientation = read_rotation(t, "[[statics]]");
        g.material = material_index(sc, t, "material");
        sc.statics.push_back(g);
    }
}

void read_planes(const Node& root, Scene& sc) {
    if (!root.has("planes")) return;
    const Node arr = root.at("planes");
    const std::vector<std::string> keys = table_keys("[[planes]]");
    for (std::size_t i = 0; i < arr.array_size(); ++i) {
        const Node t = arr.index(i);
        t.expect_keys(keys);
        PlaneSpec p;
        p.normal = unit_vector(t, "normal", p.normal);
        p.offset = t.number("offset", 0.0, -limits::kMaxCoordinate, limits::kMaxCoordinate);
        p.material = material_index(sc, t, "material");
        sc.planes.push_back(p);
    }
}

int body_ref(const Scene& sc, const Node& arr, std::size_t i) {
    const toml::value& v = arr.value().as_array().at(i);
    if (v.is_string()) {
        if (v.as_string().str == "world") return -1;
        const int b = sc.find_body(v.as_string().str);
        if (b >= 0) return b;
    }
    throw SceneError(where(v) + ": key '" + arr.path() + "': expected the name of a body or \"world\", got " + describe(v));
}

// [program]: name, max_messages, reach, and [program.params] of numbers.
void read_program(const Node& root, Scene& sc) {
    if (!root.has("program")) return;
    const Node t = root.at("program");
    t.expect_keys(table_keys("program"));
    ProgramScene& p = sc.program;
    p.enabled = true;
    p.name = t.string("name", "");
    if (p.name.empty()) t.fail("name", "a built-in program's name or a program library's path (.so)");
    p.max_messages = static_cast<int>(t.integer("max_messages", p.max_messages, 0, 1000000));
    p.reach = t.number("reach", p.reach, -1.0, 1e6);
    if (!t.has("params")) return;
    const Node params = t.at("params");
    params.require_table();
    for (const auto& kv : params.value().as_table()) p.params.emplace_back(kv.first, params.number_required(kv.first));
    std::sort(p.params.begin(), p.params.end());
}

void read_joint_params(const Node& t, JointSpec& j) {
    if (!t.has("params")) return;
    const Node p = t.at("params");
    p.require_table();
    const std::vector<std::string> listed = table_keys("[[joints]].params");  // names without the 2/3 suffix
    for (const auto& kv : p.value().as_table()) {
        std::string base = kv.first;
        if (!base.empty() && (base.back() == '2' || base.back() == '3')) base.pop_back();
        if (!joint_param_known(kv.first) || std::find(listed.begin(), listed.end(), base) == listed.end()) {
            throw SceneError(where(kv.second) + ": unknown joint parameter '" + p.key_path(kv.first) +
                             "' (expected one of: " + joint_param_names() + ")");
        }
        const limits::Range r = limits::joint_param_range(kv.first);
        j.params.emplace_back(kv.first, p.number_required(kv.first, r.lo, r.hi));
    }
}

void read_joints(const Node& root, Scene& sc) {
    if (!root.has("joints")) return;
    const Node arr = root.at("joints");
    const std::vector<std::string> keys = table_keys("[[joints]]");
    for (std::size_t i = 0; i < arr.array_size(); ++i) {
        const Node t = arr.index(i);
        t.expect_keys(keys);
        JointSpec j;
        j.name = t.string("name", "joint" + std::to_string(i));
        const std::string type = t.choice("type", "hinge", {"hinge2", "hinge", "ball", "fixed"});
        j.kind = type == "hinge2" ? JointKind::Hinge2 : type == "hinge" ? JointKind::Hinge
               : type == "ball" ? JointKind::Ball : JointKind::Fixed;
        const Node b = t.at("bodies");
        if (b.array_size() != 2) t.fail("bodies", "an array of two body names");
        j.body_a = body_ref(sc, b, 0);
        j.body_b = body_ref(sc, b, 1);
        if (j.body_a < 0 && j.body_b < 0) t.fail("bodies", "at least one body that is not \"world\"");
        if (j.body_a == j.body_b) t.fail("bodies", "two different bodies");
        j.anchor = t.vec3("anchor", j.anchor, limits::kMaxCoordinate, limits::coordinate_text());
        j.axis1 = joint_axis(t, "axis1", j.axis1);
        j.axis2 = joint_axis(t, "axis2", j.axis2);
        if (j.kind == JointKind::Hinge2 && parallel(unit_vector(t, "axis1", j.axis1), unit_vector(t, "axis2", j.axis2))) {
            t.fail("axis2", "a vector not parallel to axis1 (ODE's hinge2 needs two independent axes)");
        }
        read_joint_params(t, j);
        sc.joints.push_back(j);
    }
}

std::vector<int> joint_refs(const Scene& sc, const Node& t, const std::string& key) {
    std::vector<int> out;
    if (!t.has(key)) return out;
    const Node arr = t.at(key);
    for (std::size_t i = 0; i < arr.array_size(); ++i) {
        const toml::value& v = arr.value().as_array().at(i);
        const int j = v.is_string() ? sc.find_joint(v.as_string().str) : -1;
        if (j < 0 || sc.joints[j].kind != JointKind::Hinge2) {
            throw SceneError(where(v) + ": key '" + arr.path() + "': expected the name of a hinge2 joint, got " + describe(v));
        }
        out.push_back(j);
    }
    return out;
}

// The chassis (body 1 of the first steered, else driven, joint) and its start pose.
void controller_start(const Node& t, const Scene& sc, ControllerSpec& c) {
    const int j = c.steer_joints.empty() ? c.drive_joints.front() : c.steer_joints.front();
    c.chassis = sc.joints[static_cast<std::size_t>(j)].body_a;
    if (c.chassis < 0) t.fail(c.steer_joints.empty() ? "drive" : "steer", "joints whose first body is the chassis");
    const BodySpec& b = sc.bodies[static_cast<std::size_t>(c.chassis)];
    const Quat& q = b.orientation;  // yaw of the body's x axis
    c.start = b.position;
    c.start_heading = std::atan2(2 * (q[1] * q[2] + q[0] * q[3]), 1 - 2 * (q[2] * q[2] + q[3] * q[3]));
}

void read_controller(const Node& root, Scene& sc) {
    if (!root.has("controller")) return;
    const Node t = root.at("controller");
    t.expect_keys(table_keys("controller"));
    ControllerSpec& c = sc.controller;
    c.path = t.choice("type", "figure-eight", {"figure-eight", "straight"}) == "straight" ? DrivePath::Straight
                                                                                         : DrivePath::FigureEight;
    c.enabled = true;
    c.steer_joints = joint_refs(sc, t, "steer");
    c.drive_joints = joint_refs(sc, t, "drive");
    if (c.drive_joints.empty()) t.fail("drive", "at least one hinge2 joint name");
    controller_start(t, sc, c);
    c.radius = t.number("radius", c.radius, 1e-3);
    c.wheel_radius = t.number("wheel_radius", c.wheel_radius, 1e-3);
    c.wheelbase = t.number("wheelbase", c.wheelbase, 0.0);
    c.heading_gain = t.number("heading_gain", c.heading_gain, 0.0);
    c.track_gain = t.number("track_gain", c.track_gain, 0.0);
    c.pace_gain = t.number("pace_gain", c.pace_gain, 0.0);
    c.steer_amplitude = t.number("steer_amplitude", c.steer_amplitude, 0.0, 1.5);
    const double w = limits::kMaxMotorSpeed;
    c.speed_min = t.number("speed_min", c.speed_min, 0.0, w);
    c.speed_max = t.number("speed_max", c.speed_max, c.speed_min, w);
    c.speed_period = t.number("speed_period", c.speed_period, 1e-6);
    c.steer_gain = t.number("steer_gain", c.steer_gain, 0.0);
    c.steer_fmax = t.number("steer_fmax", c.steer_fmax, 0.0);
    c.drive_fmax = t.number("drive_fmax", c.drive_fmax, 0.0);
}

void read_run(const Node& root, RunSpec& r) {
    if (!root.has("run")) return;
    const Node t = root.at("run");
    t.expect_keys(table_keys("run"));
    if (t.has("collide")) {
        r.collide = t.string("collide", "");
        r.collide_where = where(t.at("collide").value()) + ": key 'run.collide'";
    }
    if (t.has("solver")) {
        r.solver = t.string("solver", "");
        r.solver_where = where(t.at("solver").value()) + ": key 'run.solver'";
    }
    r.threads = static_cast<int>(t.integer("threads", 0, 1, 1024));
}

void read_parallel(const Node& root, ParallelSpec& p) {
    if (!root.has("parallel")) return;
    const Node t = root.at("parallel");
    t.expect_keys(table_keys("parallel"));
    p.rebalance_threshold = t.number("rebalance_threshold", p.rebalance_threshold, 1.0);
    p.rebalance_every = static_cast<int>(t.integer("rebalance_every", p.rebalance_every, 1, 1000000));
    p.balance_colours = t.choice("balance", "colours", {"colours", "total"}) == "colours";
    p.partitioner = t.choice("partitioner", p.partitioner, {"best", "metis", "bisection"});
    p.overlap = t.boolean("overlap", p.overlap);
}

Scene build_scene(toml::value& data, const std::string& name, const std::vector<std::string>& overrides,
                  const BeforeCatoms& before_catoms) {
    for (const auto& o : overrides) apply_override(data, o);
    const Node root(data, "");
    root.expect_keys(table_keys(""));
    Scene sc;
    sc.source = name;
    read_scene_table(root, sc);
    read_run(root, sc.run);
    read_solver(root, sc.solver);
    read_materials(root, sc);
    read_planes(root, sc);
    read_bodies(root, sc);
    read_statics(root, sc);
    read_joints(root, sc);
    read_controller(root, sc);
    const CatomPlan catoms = plan_catoms(root);
    if (before_catoms) before_catoms(sc, catoms);
    const std::size_t hand_written = sc.bodies.size();
    read_catoms(root, catoms, sc);
    read_magnets(root, sc);
    read_program(root, sc);
    // Substeps hold the force passes' forces over the step: explicit stiff
    // springs such as the magnets then gain energy (docs/performance/speed-vs-error.md).
    if (sc.solver.substeps > 1 && sc.magnets.enabled && sc.magnets.strength > 0) {
        root.at("solver").fail("substeps", "1 while [magnets] are on (the magnet forces are computed once a step; held "
                                           "over substeps they pump energy into the lattice)");
    }
    // Over-relaxed (SOR w > 1), fewer sweeps a substep leave each substep's
    // overshoot of the bounce target in the impulses the next one starts
    // from: energy grows. At w <= 1 they do not (measured:
    // docs/performance/speed-vs-error.md).
    if (sc.solver.substeps > 1 && sc.solver.iterations < 3 && sc.solver.sor_w > 1.0) {
        root.at("solver").fail("iterations", "at least 3 when solver.substeps > 1 and solver.sor_w > 1 (over-relaxed, "
                                             "fewer sweeps a substep overshoot a bounce: energy grows; or set "
                                             "solver.sor_w = 1)");
    }
    if (sc.body_count() == 0) root.fail_here("the scene has no bodies (add [[bodies]] or [catoms])");
    limits::check_mass_ratio(root, sc, hand_written);
    limits::check_catom_extent(root, sc, hand_written);
    sc.guard.max_speed = limits::max_speed(sc.dt);  // [guard] max_speed may lower it
    read_guard(root, sc.guard);
    read_parallel(root, sc.parallel);
    read_checks(root, sc);
    return sc;
}

}  // namespace

namespace {

// What a scene was made from: the file's bytes and every override, in order.
std::uint64_t scene_digest(const std::string& text, const std::vector<std::string>& overrides) {
    Fnv1a h;
    h.add_bytes(text.data(), text.size());
    for (const std::string& o : overrides) {
        h.add(0xFFFFFFFFu);
        h.add_bytes(o.data(), o.size());
    }
    return h.value();
}

}  // namespace

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides,
                 const BeforeCatoms& before_catoms) {
    toml::value data = parse_toml_file(path);
    Scene sc = build_scene(data, path, overrides, before_catoms);
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    sc.digest = scene_digest(text.str(), overrides);
    return sc;
}

Scene load_scene_text(const std::string& text, const std::string& name,
                      const std::vector<std::string>& overrides) {
    std::istringstream in(text);
    toml::value data;
    try {
        data = toml::parse(in, name);
    } catch (const toml::syntax_error& e) {
        const std::size_t line = e.location().line();
        const std::string at = line == 0 ? name : name + ":" + std::to_string(line);
        throw SceneError(at + ": TOML syntax error:\n" + std::string(e.what()));
    }
    Scene sc = build_scene(data, name, overrides, {});
    sc.digest = scene_digest(text, overrides);
    return sc;
}

}  // namespace parode
