// The scene-key table (see scene_keys.hpp). Bounds come from limits.hpp and
// the defaults of scene.hpp's structs where those hold them, so a bound
// changed there changes the reference; the rest restate the readers, and
// tests/test_scene_keys.cpp loads each bound and default to hold them equal.
// Trade-off: one hand-written row per key (about 140), plainer to review than
// a schema the readers would interpret, at the price of that test.
#include "scene/scene_keys.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "scene/generators.hpp"
#include "scene/limits.hpp"
#include "scene/scene.hpp"

namespace parode {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Short: 0.005, 1256.64, 1e4, 1e-9 (exponents from 1e4 up and below 1e-3).
std::string fmt(double x) {
    char buf[32];
    const double a = std::fabs(x);
    std::snprintf(buf, sizeof buf, a != 0 && (a >= 1e4 || a < 1e-3) ? "%.5e" : "%g", x);
    std::string s = buf;
    const std::size_t e = s.find('e');
    if (e == std::string::npos) return s;
    std::string mantissa = s.substr(0, e);
    if (mantissa.find('.') != std::string::npos) {
        mantissa.erase(mantissa.find_last_not_of('0') + 1);
        if (mantissa.back() == '.') mantissa.pop_back();
    }
    return mantissa + "e" + std::to_string(std::atoi(s.c_str() + e + 1));
}

// A row being written: what differs from a key without unit, range or default.
struct K {
    SceneKey k;
    K(const char* key, const char* type) {
        k.key = key;
        k.type = type;
        k.lo = k.hi = k.default_value = kNaN;
    }
    K& unit(const char* u) { k.unit = u; return *this; }
    K& in(double lo, double hi) { k.lo = lo; k.hi = hi; return *this; }
    K& range(const std::string& text) { k.range = text; return *this; }
    K& each(double lo, double hi) { k.bound = KeyBound::Each; return in(lo, hi); }
    K& length(double hi) { k.bound = KeyBound::Length; return in(kNaN, hi); }
    K& def(double v) { k.default_value = v; return *this; }
    K& def(const std::string& text) { k.default_text = text; return *this; }
    K& dep(const char* keys) { k.depends_on = keys; return *this; }
    K& means(const char* m) { k.meaning = m; return *this; }
};

K num(const char* key) { return K(key, "number"); }
K integer(const char* key) { return K(key, "integer"); }
K boolean(const char* key, bool def) { return K(key, "bool").def(def ? "true" : "false"); }
K str(const char* key) { return K(key, "string"); }
K vec(const char* key) { return K(key, "[x, y, z]"); }
K table(const char* key) { return K(key, "table"); }
K tables(const char* key) { return K(key, "array of tables"); }

std::string range_text(const SceneKey& k) {
    const bool lo = std::isfinite(k.lo), hi = std::isfinite(k.hi);
    const std::string prefix = k.bound == KeyBound::Each ? "each " : "";
    if (k.bound == KeyBound::Length) return hi ? "|v| <= " + fmt(k.hi) : "";
    if (lo && hi) return prefix + (k.bound == KeyBound::Each ? "in " : "") + "[" + fmt(k.lo) + ", " + fmt(k.hi) + "]";
    if (lo) return prefix + ">= " + fmt(k.lo);
    if (hi) return prefix + "<= " + fmt(k.hi);
    return std::isnan(k.lo) ? "" : "any";
}

void add(std::vector<SceneKey>& out, const char* table, std::initializer_list<K> rows) {
    for (const K& r : rows) {
        SceneKey k = r.k;
        k.table = table;
        if (k.range.empty()) k.range = range_text(k);
        if (k.default_text.empty() && std::isfinite(k.default_value)) k.default_text = fmt(k.default_value);
        out.push_back(k);
    }
}

// Shared by [[bodies]] and [[statics]].
K shape() { return K("shape", "one of \"sphere\", \"box\", \"capsule\", \"cylinder\"").def("\"sphere\"").means("the geom's shape"); }
K radius() {
    return num("radius").unit("m").in(limits::kMinSize, limits::kMaxSize).def(Shape{}.radius).means("sphere, capsule, cylinder; not read for a box");
}
K length() {
    return num("length").unit("m").in(limits::kMinSize, limits::kMaxSize).def(Shape{}.length).means("capsule, cylinder, along the body's z; not read otherwise");
}
K size() { return vec("size").unit("m").each(limits::kMinSize, limits::kMaxSize).def("[1, 1, 1]").means("box sides; not read otherwise"); }
K position() {
    return vec("position").unit("m").each(-limits::kMaxCoordinate, limits::kMaxCoordinate).def("[0, 0, 0]").means("centre");
}
K rotation() { return table("rotation").def("none").means("orientation, {axis = [x, y, z], angle = rad}"); }
K material() { return str("material").def("first material").means("a [[materials]] name"); }
void rotation_keys(std::vector<SceneKey>& out, const char* table) {
    add(out, table, {vec("axis").def("[0, 0, 1]").range("non-zero").means("rotation axis (scaled to length 1)"),
                     num("angle").unit("rad").in(-kInf, kInf).def("required").means("rotation angle about the axis")});
}

std::vector<SceneKey> build() {
    const Scene sc;
    const SolverSpec sv;
    const Material mat;
    const MagnetModel mag;
    const ControllerSpec ctl;
    const ParallelSpec par;
    const double dt = sc.dt;
    std::vector<SceneKey> out;
    add(out, "",
        {table("scene").def("required").means("the run: name, seed, steps, time step, gravity"),
         table("solver").def("the defaults below").means("ODE's world and contact settings"),
         tables("materials").def("one material \"default\" with the defaults below")
             .means("contact surfaces: a contact takes sqrt(mu_a mu_b) (friction pyramid) and the larger of the two "
                    "materials' other values"),
         tables("planes").def("none").means("infinite static planes normal . x = offset"),
         tables("bodies").def("none").means("dynamic bodies, one geom each; global ids 0, 1, ... in file order"),
         tables("statics").def("none").means("static geoms (ramps, walls)"),
         tables("joints").def("none").means("ODE joints between two bodies or a body and \"world\"; contacts between "
                                            "two jointed bodies are ignored"),
         table("catoms").def("none").means("the catom prism: nx = ny = ceil(cbrt(count)) spheres a layer, layers "
                                           "upwards; ids after the [[bodies]]"),
         table("magnets").def("off").means("the catom magnets; writing the table turns them on"),
         table("controller").def("none").means("the buggy driver on hinge2 joints: axis 1 steers, axis 2 drives"),
         table("program").def("none").means("the program every catom runs (event handlers, messages, magnets)"),
         table("guard").def("the defaults below").means("what stops a runaway run (a NaN always does)"),
         table("checks").def("none").means("pass criteria of the run (exit 5 when one fails); unset ones are not checked"),
         table("parallel").def("the defaults below").means("load balance of distributed runs"),
         table("run").def("none").means("backends and threads the scene asks for; the command line overrides them")});
    add(out, "scene",
        {str("name").range("non-empty").def("required").means("the scene's name in reports and checkpoints"),
         K("description", "any").means("free text for people; not read"),
         integer("seed").in(0, static_cast<double>(std::numeric_limits<long>::max())).range("[0, 2^63 - 1]")
             .def(static_cast<double>(sc.seed)).means("seeds the catom jitter and ODE's dRand (QuickStep's row order)"),
         integer("steps").in(0, 1e9).def(sc.steps).means("steps of `parode run` without --steps or --duration"),
         num("dt").unit("s").in(1e-9, 1.0).def(dt).means("time step"),
         vec("gravity").unit("m/s^2").length(limits::kMaxGravity).def("[0, 0, -9.81]").means("gravitational acceleration"),
         integer("observe_every").in(1, 1e9).def(sc.observe_every)
             .means("steps between observations (diagnostics, energy guard, checks)")});
    add(out, "solver",
        {K("stepper", "one of \"quick\", \"world\"").def("\"quick\"").means("ODE's dWorldQuickStep or dWorldStep"),
         integer("iterations").in(1, 100000).def(sv.iterations).means("QuickStep and contact-solver sweeps a step"),
         num("sor_w").in(0.01, 2.0).def(sv.sor_w).means("SOR over-relaxation"),
         num("erp").in(0, 1).def(sv.erp).means("world ERP: share of a joint or contact error corrected a step"),
         num("cfm").in(0, 1).def(sv.cfm).means("world CFM: constraint softness"),
         num("contact_surface_layer").unit("m").in(0, kInf).def(sv.contact_surface_layer)
             .means("depth a contact may sink uncorrected"),
         num("contact_max_correcting_vel").unit("m/s").in(0, kInf).def(sv.contact_max_correcting_vel)
             .means("fastest correction of a contact"),
         integer("max_contacts").in(1, 64).def(sv.max_contacts).means("contacts per geom pair"),
         boolean("warm_start", sv.warm_start).means("parode's contact solver starts from last step's impulses"),
         integer("substeps").in(1, 64).def(sv.substeps)
             .means("parode's contact solver: substeps a step, `iterations` sweeps each (at least 3 unless `sor_w` <= 1), one collision"),
         integer("adaptive_sweeps").in(1, 100000).def(sv.adaptive_sweeps)
             .means("the adaptive solver: sweeps of every cell a step (a substep), before its active sweeps"),
         num("tolerance").unit("m/s").in(0, kInf).def(sv.tolerance)
             .means("the adaptive solver: a cell is swept again while its last sweep changed a relative velocity by more"),
         integer("extra_sweeps").in(0, 100000).def(sv.extra_sweeps)
             .means("the adaptive solver: most sweeps of the cells still changing, after `adaptive_sweeps`"),
         table("auto_disable").def("off").means("ODE's auto-disable (resting bodies sleep); writing the table turns it on")});
    add(out, "solver.auto_disable",
        {boolean("enabled", true).means("true once the table is written"),
         num("linear").unit("m/s").in(0, kInf).def(sv.auto_disable_linear).means("speed below which a body rests"),
         num("angular").unit("rad/s").in(0, kInf).def(sv.auto_disable_angular).means("turn rate below which a body rests"),
         integer("steps").in(1, 1e6).def(sv.auto_disable_steps).means("steps at rest before a body sleeps")});
    add(out, "program",
        {str("name").def("required").means("a built-in program (gradient, sculpt, wave) or a program library (.so)"),
         integer("max_messages").in(0, 1e6).def(ProgramScene{}.max_messages).means("messages a catom may send a step"),
         num("reach").unit("m").in(-1, 1e6).def("magnets.cutoff, else radius / 10")
             .means("how far beyond the two radii a catom sees neighbours"),
         K("params", "table of numbers").def("none").means("any names: numbers the program reads by name")});
    add(out, "[[materials]]",
        {str("name").range("non-empty, unique").def("required").means("what bodies, statics, planes and catoms name"),
         num("mu").in(0, kInf).def(mat.mu).means("Coulomb friction"),
         num("bounce").in(0, 1).def(mat.bounce).means("restitution"),
         num("bounce_vel").unit("m/s").in(0, kInf).def(mat.bounce_vel).means("slowest approach that bounces"),
         num("soft_erp").in(0, 1).def("world's erp").means("contact ERP"),
         num("soft_cfm").in(0, kInf).def("world's cfm").means("contact CFM"),
         num("slip").in(0, kInf).def(mat.slip).means("force-dependent slip, both friction directions")});
    add(out, "[[planes]]",
        {vec("normal").range("non-zero").def("[0, 0, 1]").means("normal (scaled to length 1)"),
         num("offset").unit("m").in(-limits::kMaxCoordinate, limits::kMaxCoordinate).def(PlaneSpec{}.offset)
             .means("normal . x = offset"),
         material()});
    const std::string speed = "|v| <= 10 m / dt (" + fmt(limits::max_speed(dt)) + " at dt = " + fmt(dt) + ")";
    const std::string turn = "|w| <= 2 pi / dt (" + fmt(limits::max_turn_rate(dt)) + " at dt = " + fmt(dt) + ")";
    add(out, "[[bodies]]",
        {str("name").range("non-empty, unique").def("required").means("what joints, checks and the controller name"),
         shape(), radius(), length(), size(),
         num("mass").unit("kg").in(limits::kMinMass, limits::kMaxMass).def(BodySpec{}.mass)
             .means("at most 1e6 x the lightest body's"),
         position(), rotation(),
         vec("velocity").unit("m/s").length(limits::max_speed(dt)).range(speed).dep("scene.dt").def("[0, 0, 0]")
             .means("initial velocity"),
         vec("angular_velocity").unit("rad/s").length(limits::max_turn_rate(dt)).range(turn).dep("scene.dt")
             .def("[0, 0, 0]").means("initial angular velocity"),
         material(),
         boolean("catom", false).means("a catom (magnets act on it); spheres only")});
    rotation_keys(out, "[[bodies]].rotation");
    add(out, "[[statics]]",
        {str("name").def("\"static\" + index").means("its name in outputs"), shape(), radius(), length(), size(),
         position(), rotation(), material()});
    rotation_keys(out, "[[statics]].rotation");
    add(out, "[[joints]]",
        {str("name").def("\"joint\" + index").means("what [controller] steer and drive name"),
         K("type", "one of \"hinge2\", \"hinge\", \"ball\", \"fixed\"").def("\"hinge\"").means("ODE joint type"),
         K("bodies", "[a, b]").range("two bodies, or one and \"world\"").def("required").means("[[bodies]] names"),
         vec("anchor").unit("m").each(-limits::kMaxCoordinate, limits::kMaxCoordinate).def("[0, 0, 0]")
             .means("hinge2, hinge, ball"),
         vec("axis1").range("non-zero").def("[0, 0, 1]").means("hinge axis; hinge2: the steering axis"),
         vec("axis2").range("non-zero, not parallel to axis1").def("[0, 1, 0]").means("hinge2: the wheel axis"),
         table("params").def("ODE's").means("ODE joint parameters; add 2 or 3 to a name for the second or third axis")});
    auto param = [](const char* name) {
        const limits::Range r = limits::joint_param_range(name);
        return num(name).in(r.lo, r.hi).def("ODE's");
    };
    add(out, "[[joints]].params",
        {param("lo_stop").unit("rad").means("stops: lowest and highest angle"),
         param("hi_stop").unit("rad").means("stops: lowest and highest angle"),
         param("vel").unit("rad/s").means("motor target speed"),
         param("fmax").unit("N m").means("motor's largest torque (0: no motor)"),
         param("fudge_factor").means("scales the motor at the stops"),
         param("bounce").means("restitution of the stops"),
         param("erp").means("joint ERP and CFM"), param("cfm").means("joint ERP and CFM"),
         param("stop_erp").means("ERP and CFM of the stops"), param("stop_cfm").means("ERP and CFM of the stops"),
         param("suspension_erp").means("hinge2 suspension ERP and CFM"),
         param("suspension_cfm").means("hinge2 suspension ERP and CFM")});
    add(out, "catoms",
        {integer("count").in(1, 1e8).def(1000).means("number of catoms"),
         num("radius").unit("m").in(limits::kMinSize, limits::kMaxSize).def(CatomPlan{}.radius).means("sphere radius"),
         num("mass").unit("kg").in(limits::kMinMass, limits::kMaxMass).def(1.0).means("mass of each"),
         K("layout", "one of \"prism\"").def("\"prism\"").means("the only layout"),
         num("spacing").unit("m").in(0.5, limits::kMaxSize).range("[radius, 1e4]").dep("catoms.radius")
             .def(1.0).def("2 x radius").means("centre to centre; the whole prism within |x| <= 1e6"),
         num("jitter").in(0, 1).def(0.01).means("random offsets, a fraction of the radius (scene.seed)"),
         str("material").def("first material").means("a [[materials]] name"),
         vec("base").unit("m").each(-limits::kMaxCoordinate, limits::kMaxCoordinate).def("[0, 0, 0]")
             .means("centre of the prism's bottom face"),
         vec("velocity").unit("m/s").length(limits::max_speed(dt)).range(speed).dep("scene.dt").def("[0, 0, 0]")
             .means("every catom's initial velocity")});
    add(out, "magnets",
        {boolean("enabled", true).means("true once the table is written"),
         K("layout", "one of \"axes6\", \"cube8\"").def("\"axes6\"")
             .means("poles at +-x, +-y, +-z (axes6) or the 8 cube corners (cube8)"),
         num("strength").unit("N m^2").in(0, kInf).def(mag.strength).means("k, the pole-pole force constant"),
         num("softening").unit("m").in(1e-9, kInf).def(mag.softening).means("eps, softens the force at short range"),
         num("cutoff").unit("m").in(1e-9, kInf).def(mag.cutoff).means("range of a pole pair's force"),
         K("off", "[ids]").range("catom ids").def("[]").means("catoms whose magnets are off")});
    const double w = limits::kMaxMotorSpeed;
    add(out, "controller",
        {K("type", "one of \"figure-eight\", \"straight\"").def("\"figure-eight\"")
             .means("track from the chassis' start pose: a left circle then a right one, or straight ahead"),
         K("steer", "[names]").range("hinge2 joints").def("[]").means("steered joints; the first's body 1 is the chassis"),
         K("drive", "[names]").range("hinge2 joints, >= 1").def("required").means("driven joints (the chassis when no steer)"),
         num("radius").unit("m").in(1e-3, kInf).def(ctl.radius).means("each circle of the eight"),
         num("wheel_radius").unit("m").in(1e-3, kInf).def(ctl.wheel_radius).means("turns wheel speed into track distance"),
         num("wheelbase").unit("m").in(0, kInf).def(ctl.wheelbase).means("steered to rear axle (feedforward atan(wheelbase / radius))"),
         num("heading_gain").in(0, kInf).def(ctl.heading_gain).means("rad of steering per rad of heading error"),
         num("track_gain").unit("1/m").in(0, kInf).def(ctl.track_gain).means("heading correction atan(track_gain x distance off the track)"),
         num("pace_gain").unit("1/s").in(0, kInf).def(ctl.pace_gain).means("extra speed (m/s) per m behind the schedule"),
         num("steer_amplitude").unit("rad").in(0, 1.5).def(ctl.steer_amplitude).means("largest steering angle"),
         num("speed_min").unit("rad/s").in(0, w).def(ctl.speed_min).means("wheel speed schedule: a sine between the two"),
         num("speed_max").unit("rad/s").in(ctl.speed_min, w).range("[speed_min, 1e4], checked only when written")
             .dep("controller.speed_min").def(ctl.speed_max).means("wheel speed schedule: a sine between the two"),
         num("speed_period").unit("s").in(1e-6, kInf).def(ctl.speed_period).means("period of the sine"),
         num("steer_gain").unit("1/s").in(0, kInf).def(ctl.steer_gain).means("steering servo: rad/s per rad of error"),
         num("steer_fmax").unit("N m").in(0, kInf).def(ctl.steer_fmax).means("steering servo's largest torque"),
         num("drive_fmax").unit("N m").in(0, kInf).def(ctl.drive_fmax).means("wheel motor's largest torque")});
    add(out, "guard",
        {boolean("energy", GuardSpec{}.energy).means("stop when the total energy passes its bound"),
         num("max_energy_gain").unit("J").in(0, kInf).def("automatic")
             .means("the bound over the initial energy; automatic: kinetic + potential headroom + magnets + motors"),
         num("max_speed").unit("m/s").in(1e-9, limits::max_speed(dt)).range("[1e-9, 10 m / dt]").dep("scene.dt")
             .def(limits::max_speed(dt)).def("10 m / dt").means("stop when a body is faster")});
    add(out, "checks",
        {num("max_penetration").unit("m").in(0, kInf).def("unset").means("deepest contact, any observed step"),
         num("max_final_penetration").unit("m").in(0, kInf).def("unset").means("deepest contact at the end"),
         num("max_energy_gain").unit("J").in(-kInf, kInf).def("unset").means("energy over the initial, any observed step"),
         num("max_displacement").unit("m").in(0, kInf).def("unset").means("farthest a catom (any body if none) moved, at the end"),
         num("max_final_speed").unit("m/s").in(0, kInf).def("unset").means("fastest body at the end"),
         num("min_disabled").in(0, 1).def("unset").means("share of bodies asleep at the end"),
         integer("max_escaped").in(0, 1e9).def("unset").means("catoms outside the start footprint (+ a radius) at the end"),
         tables("position").def("none").means("bounds on one coordinate of one body")});
    add(out, "[[checks.position]]",
        {K("body", "string or integer").range("a [[bodies]] name or a body id").def("required").means("the body"),
         K("axis", "one of \"x\", \"y\", \"z\"").def("\"z\"").means("the coordinate"),
         num("min").unit("m").in(-kInf, kInf).range("min, max or both").def("unset").means("lowest allowed"),
         num("max").unit("m").in(-kInf, kInf).range(">= min").def("unset").means("highest allowed"),
         boolean("always", false).means("at every observed step, not only at the end")});
    add(out, "parallel",
        {num("rebalance_threshold").in(1, kInf).def(par.rebalance_threshold)
             .means("repartition when the busiest rank's load passes this x the mean"),
         integer("rebalance_every").in(1, 1e6).def(par.rebalance_every).means("steps between load measurements"),
         K("balance", "one of \"colours\", \"total\"").def("\"colours\"")
             .means("what the partition balances: each colour's work and the bodies, or each rank's total"),
         K("partitioner", "one of \"best\", \"metis\", \"bisection\"").def("\"best\"")
             .means("who cuts the cells: the better balanced of METIS and coordinate bisection (past 2^18 cells: the bisection, by every rank together), or one of them"),
         boolean("overlap", true).means("relax a colour's interior cells while its boundary corrections travel")});
    add(out, "run",
        {str("collide").def("unset: \"grid\"").means("collision backend (checked when the run starts)"),
         str("solver").def("unset: \"parallel\"").means("solver (checked when the run starts)"),
         integer("threads").in(1, 1024).def("unset")
             .means("threads (unset: OMP_NUM_THREADS, else Slurm's CPUs per task, else every core)")});
    return out;
}

// The table a key of type table / array of tables opens: "[[bodies]]", "solver.auto_disable".
std::string child_table(const SceneKey& k) {
    const std::string dotted = k.table.empty() ? k.key : k.table + "." + k.key;
    return k.type == "array of tables" ? "[[" + dotted + "]]" : dotted;
}

bool opens_table(const SceneKey& k) { return k.type == "table" || k.type == "array of tables"; }

// "[solver]", "[[bodies]]", "[[bodies]].rotation" as a heading shows them.
std::string shown(const std::string& table) {
    return "`" + (table.rfind("[[", 0) == 0 ? table : "[" + table + "]") + "`";
}

bool same_row(const SceneKey& a, const SceneKey& b) {
    return a.type == b.type && a.unit == b.unit && a.range == b.range && a.default_text == b.default_text &&
           a.meaning == b.meaning;
}

std::vector<const SceneKey*> rows_of(const std::string& table) {
    std::vector<const SceneKey*> rows;
    for (const SceneKey& k : scene_keys()) {
        if (k.table == table) rows.push_back(&k);
    }
    return rows;
}

bool same_table(const std::vector<const SceneKey*>& a, const std::vector<const SceneKey*>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (a[i]->key != b[i]->key || !same_row(*a[i], *b[i])) return false;
    }
    return true;
}

// A table cell: "|v|" would end the cell.
std::string cell(const std::string& text) {
    std::string out;
    for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
    return out;
}

// One table's rows: keys whose other columns are equal share a row; columns
// empty in every row are left out.
void markdown_rows(std::ostringstream& os, const std::vector<const SceneKey*>& rows) {
    std::vector<std::vector<std::string>> cells;  // key, type, unit, range, default, meaning
    for (const SceneKey* k : rows) {
        if (opens_table(*k)) continue;  // its own row opens it
        const std::vector<std::string> row{"`" + k->key + "`", cell(k->type), cell(k->unit), cell(k->range),
                                           cell(k->default_text), cell(k->meaning)};
        if (!cells.empty() && std::equal(row.begin() + 1, row.end(), cells.back().begin() + 1)) {
            cells.back()[0] += ", " + row[0];
            continue;
        }
        cells.push_back(row);
    }
    for (const auto& r : cells) {
        os << "|";
        for (const auto& c : r) os << " " << c << " |";
        os << "\n";
    }
}

}  // namespace

const std::vector<SceneKey>& scene_keys() {
    static const std::vector<SceneKey> keys = build();
    return keys;
}

std::vector<std::string> scene_tables() {
    std::vector<std::string> out;
    for (const SceneKey& k : scene_keys()) {
        if (out.empty() || out.back() != k.table) out.push_back(k.table);
    }
    return out;
}

std::vector<std::string> table_keys(const std::string& table) {
    std::vector<std::string> out;
    for (const SceneKey& k : scene_keys()) {
        if (k.table == table) out.push_back(k.key);
    }
    return out;
}

std::string scene_keys_markdown() {
    // Each table in order, with the entry that opens it (its heading).
    std::vector<std::pair<std::string, const SceneKey*>> tables;
    for (const std::string& t : scene_tables()) {
        for (const SceneKey& k : scene_keys()) {
            if (opens_table(k) && child_table(k) == t) tables.emplace_back(t, &k);
        }
    }
    std::ostringstream os;
    os << "| key | type | unit | range | default | meaning |\n| --- | --- | --- | --- | --- | --- |\n";
    std::vector<std::string> done;
    for (std::size_t i = 0; i < tables.size(); ++i) {
        const std::string& t = tables[i].first;
        if (std::find(done.begin(), done.end(), t) != done.end()) continue;
        const auto rows = rows_of(t);
        std::string names = shown(t);
        for (std::size_t j = i + 1; j < tables.size(); ++j) {  // identical tables share one
            if (same_table(rows, rows_of(tables[j].first)) && same_row(*tables[i].second, *tables[j].second)) {
                names += ", " + shown(tables[j].first);
                done.push_back(tables[j].first);
            }
        }
        const SceneKey& opener = *tables[i].second;
        const std::string def = opener.default_text == "required" ? "required" : "absent: " + opener.default_text;
        os << "| **" << names << "** | | | | " << cell(def) << " | **" << cell(opener.meaning) << "** |\n";
        markdown_rows(os, rows);
    }
    return os.str();
}

nlohmann::json scene_keys_json() {
    nlohmann::json out = nlohmann::json::array();
    for (const SceneKey& k : scene_keys()) {
        nlohmann::json j = {{"table", k.table}, {"key", k.key}, {"type", k.type}, {"unit", k.unit},
                            {"range", k.range}, {"default", k.default_text}, {"meaning", k.meaning}};
        if (std::isfinite(k.lo)) j["lo"] = k.lo, j["lo_inclusive"] = k.lo_inclusive;
        if (std::isfinite(k.hi)) j["hi"] = k.hi, j["hi_inclusive"] = k.hi_inclusive;
        if (!std::isnan(k.lo) || !std::isnan(k.hi)) {
            j["bound"] = k.bound == KeyBound::Each ? "each component" : k.bound == KeyBound::Length ? "length" : "value";
        }
        if (std::isfinite(k.default_value)) j["default_value"] = k.default_value;
        if (!k.depends_on.empty()) j["depends_on"] = k.depends_on;
        out.push_back(j);
    }
    return out;
}

}  // namespace parode
