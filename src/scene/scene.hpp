// The Scene: plain data describing everything a run simulates, independent of
// ODE. Scene files (scene_file.cpp) and generators (the catom prism) fill it;
// World (world.cpp) turns it into ODE objects.
// Trade-off: a closed set of shapes, joints and controllers keeps validation
// exhaustive and the model readable; new kinds are added here explicitly.
#pragma once
#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace parode {

using Vec3 = std::array<double, 3>;
using Quat = std::array<double, 4>;  // ODE order: w, x, y, z

enum class ShapeKind { Sphere, Box, Capsule, Cylinder };

struct Shape {
    ShapeKind kind = ShapeKind::Sphere;
    double radius = 0.5;        // sphere, capsule, cylinder
    double length = 1.0;        // capsule, cylinder (along body z)
    Vec3 size{1.0, 1.0, 1.0};   // box
};

// Radius of the smallest sphere about the shape's centre that holds it
// (capsule and cylinder: r + length / 2, an upper bound).
double bounding_radius(const Shape& shape);

struct Material {
    std::string name;
    double mu = 0.5;
    double bounce = 0.0;
    double bounce_vel = 0.1;
    double soft_erp = -1.0;  // < 0: use the world's ERP
    double soft_cfm = -1.0;  // < 0: use the world's CFM
    double slip = 0.0;       // force-dependent slip (both directions)
};

struct BodySpec {
    std::string name;
    Shape shape;
    double mass = 1.0;
    Vec3 position{0, 0, 0};
    Quat orientation{1, 0, 0, 0};
    Vec3 velocity{0, 0, 0};
    Vec3 angular_velocity{0, 0, 0};
    int material = 0;
    bool catom = false;    // part of the catom ensemble
    bool magnets = false;  // magnets switched on (catoms only)
};

struct StaticGeom {  // a geom with no body: ramps, walls
    std::string name;
    Shape shape;
    Vec3 position{0, 0, 0};
    Quat orientation{1, 0, 0, 0};
    int material = 0;
};

struct PlaneSpec {  // infinite plane: normal . x = offset
    Vec3 normal{0, 0, 1};
    double offset = 0.0;
    int material = 0;
};

enum class JointKind { Hinge2, Hinge, Ball, Fixed };

struct JointSpec {
    std::string name;
    JointKind kind = JointKind::Hinge;
    int body_a = -1;  // -1: the static environment
    int body_b = -1;
    Vec3 anchor{0, 0, 0};
    Vec3 axis1{0, 0, 1};
    Vec3 axis2{0, 1, 0};
    // ODE joint parameters, by name (e.g. "lo_stop", "suspension_erp", "hi_stop2").
    std::vector<std::pair<std::string, double>> params;
};

// Monopoles at body-fixed points on every magnetised catom's surface (README).
struct MagnetModel {
    bool enabled = false;
    std::vector<Vec3> directions;  // unit vectors in the body frame
    std::vector<double> charges;   // polarity x strength multiplier, per pole
    double strength = 1.0;         // k in F = k q_i q_j d / (|d|^2 + eps^2)^(3/2)
    double softening = 0.05;       // eps (m)
    double cutoff = 0.25;          // pole-pole interaction range (m)
};

// The catom program every catom runs (programs/program.hpp): a built-in name
// or a shared library's path, its message budget, how far neighbours reach
// and its numeric parameters.
struct ProgramScene {
    bool enabled = false;
    std::string name;
    int max_messages = 8;  // per catom per step
    double reach = -1;     // beyond the two radii (m); negative: the magnets' cutoff, else a tenth of the radius
    std::vector<std::pair<std::string, double>> params;
};

// The deterministic buggy driver (forces/controller.hpp): the chassis follows a
// figure-eight track (or a straight line) from its start pose on a schedule of
// slowly varying speed.
enum class DrivePath { FigureEight, Straight };

struct ControllerSpec {
    bool enabled = false;
    DrivePath path = DrivePath::FigureEight;
    std::vector<int> steer_joints;  // hinge2 joints whose axis 1 steers
    std::vector<int> drive_joints;  // hinge2 joints whose axis 2 drives
    int chassis = -1;               // body steered along the track: body 1 of the first steer (else drive) joint
    Vec3 start{0, 0, 0};            // the chassis' start position: where the track begins
    double start_heading = 0.0;     // the chassis' start yaw (rad): the track's first direction
    double radius = 2.0;            // m, radius of each circle of the eight
    double wheel_radius = 0.18;     // m, converts the wheel speed into distance along the track
    double wheelbase = 0.7;         // m, steered axle to the rear axle (steering feedforward)
    double heading_gain = 2.0;      // rad of steering per rad of heading error
    double track_gain = 1.0;        // 1/m: heading correction atan(track_gain x cross-track error)
    double pace_gain = 1.0;         // 1/s: extra speed (m/s) per metre behind the schedule
    double steer_amplitude = 0.5;   // rad, largest steering angle
    double speed_min = 5.0;         // wheel rad/s of the schedule
    double speed_max = 15.0;
    double speed_period = 20.0;     // s per speed cycle
    double steer_gain = 10.0;       // steering servo: rad/s per rad of angle error
    double steer_fmax = 5.0;
    double drive_fmax = 1.0;
};

enum class Stepper { Quick, World };

struct SolverSpec {
    Stepper stepper = Stepper::Quick;
    int iterations = 20;
    double sor_w = 1.3;
    double erp = 0.2;
    double cfm = 1e-5;
    double contact_surface_layer = 0.001;
    double contact_max_correcting_vel = 1e9;
    int max_contacts = 4;
    bool warm_start = true;  // project contact solver only
    int substeps = 1;        // project contact solver only: substeps a step (contact_solver.hpp)
    // The adaptive contact solver only (solve/active_sweeps.cpp): sweeps of
    // every cell, then sweeps of the cells whose last relaxation changed a
    // relative velocity by more than `tolerance` (m/s), at most `extra_sweeps`.
    int adaptive_sweeps = 8;
    double tolerance = 0.03;
    int extra_sweeps = 30;
    bool auto_disable = false;
    double auto_disable_linear = 0.01;
    double auto_disable_angular = 0.01;
    int auto_disable_steps = 10;
};

// The run guard (guard.hpp): a non-finite state always stops the run; these
// bounds stop a runaway too.
struct GuardSpec {
    bool energy = true;                     // stop when the total energy grows past the bound
    std::optional<double> max_energy_gain;  // J over the initial energy; unset: automatic bound
    double max_speed = 0;                   // m/s; 0: no speed bound (the reader sets the bound of limits.hpp)
};

// A bound on one coordinate of one body, at the end of the run or (always)
// at every observed step.
struct PositionCheck {
    int body = 0;
    int axis = 2;  // 0 x, 1 y, 2 z
    double min = -1e300, max = 1e300;
    bool always = false;
};

// Pass criteria of a run ([checks], checks.hpp); unset bounds are not checked.
struct CheckSpec {
    std::optional<double> max_penetration;   // m, over observed steps
    std::optional<double> max_final_penetration;  // m, at the end
    std::optional<double> max_energy_gain;   // J over the initial total energy, every observed step
    std::optional<double> max_displacement;  // m, any catom (or body) from its start, at the end
    std::optional<double> max_final_speed;   // m/s, any body at the end
    std::optional<double> min_disabled;      // fraction of bodies asleep at the end
    std::optional<long> max_escaped;         // catoms outside the initial footprint at the end
    std::vector<PositionCheck> positions;
    bool any() const;
};

// The catom ensemble ([catoms]): a prism of identical spheres that is never
// stored body by body. Catom n (global id first + n) is generated on demand,
// so a process builds only the ids it holds; its jitter comes from the n-th
// draws of a counter-based generator, the same bits whichever ids are built.
struct CatomBlock {
    std::size_t first = 0;  // global id of catom 0 (the [[bodies]] come first)
    std::size_t count = 0;
    BodySpec proto;         // shape, mass, material, velocity, magnets
    double spacing = 1.0;
    double jitter = 0.0;    // m
    Vec3 base{0, 0, 0};     // centre of the prism's bottom face
    long dims[3] = {1, 1, 1};
    std::uint64_t seed = 1;
    Vec3 position(std::size_t n) const;
};

// [run]: the backends and threads a scene asks for (the command line
// overrides them). Empty / 0: not given. The names are checked against the
// registries when the run starts (`where` names file and line).
struct RunSpec {
    std::string collide, solver;
    int threads = 0;
    std::string collide_where, solver_where;
};

// [parallel]: how a distributed run keeps its load balanced.
struct ParallelSpec {
    double rebalance_threshold = 1.25;  // repartition when max load / mean load exceeds this
    int rebalance_every = 10;           // steps between load measurements
    // The partition balances each colour's work (the solver waits for the
    // slowest rank after every colour), or only each rank's total.
    bool balance_colours = true;
    // Who cuts the cells: "best" (the better balanced of METIS's partition and
    // a recursive coordinate bisection), "metis" or "bisection".
    std::string partitioner = "best";
    // The solver relaxes a colour's interior cells while the corrections of
    // its boundary cells travel; off: every cell before the exchange.
    bool overlap = true;
};

struct Scene {
    std::string name;
    std::string source;  // file it came from
    std::uint64_t digest = 0;  // of the file's bytes and the overrides (checkpoints name their scene by it)
    std::uint64_t seed = 1;
    int steps = 1000;
    double dt = 0.005;
    Vec3 gravity{0, 0, -9.81};
    int observe_every = 10;
    SolverSpec solver;
    std::vector<Material> materials;
    std::vector<BodySpec> bodies;  // the [[bodies]]: global ids 0 .. bodies.size() - 1
    CatomBlock catoms;             // then the generated catoms
    std::vector<std::uint32_t> magnets_off;  // generated catoms with magnets off, ascending
    std::vector<StaticGeom> statics;
    std::vector<PlaneSpec> planes;
    std::vector<JointSpec> joints;
    MagnetModel magnets;
    ControllerSpec controller;
    ProgramScene program;
    GuardSpec guard;
    CheckSpec checks;
    ParallelSpec parallel;
    RunSpec run;

    // Every body, [[bodies]] and generated catoms: global ids 0 .. body_count() - 1.
    std::size_t body_count() const { return bodies.size() + catoms.count; }
    // The spec of body `gid` (generated for a catom).
    BodySpec body(std::size_t gid) const;
    bool body_magnets(std::size_t gid) const;
    // Whether body `gid` is a catom (of [catoms], or a [[bodies]] entry with catom = true).
    bool body_is_catom(std::size_t gid) const { return gid < bodies.size() ? bodies[gid].catom : gid < body_count(); }
    // Largest bounding-sphere radius of any body.
    double max_bounding_radius() const;
    std::size_t catom_count() const;
    // How far beyond the two radii catoms are neighbours to their programs:
    // program.reach, by default the magnets' cutoff, else a tenth of the
    // first catom's radius; and the centre distance that makes, at most
    // (twice the largest catom radius plus the reach).
    double program_reach() const;
    double program_range() const;
    std::size_t magnet_count() const;  // bodies with magnets on
    bool any_magnets() const;
    int find_body(const std::string& name) const;
    int find_joint(const std::string& name) const;
};

// The solver settings as the run report and trajectory files record them.
nlohmann::json solver_json(const SolverSpec& s);

}  // namespace parode
