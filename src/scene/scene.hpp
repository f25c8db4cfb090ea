// The Scene: plain data describing everything a run simulates, independent of
// ODE. Scene files (scene_file.cpp) and generators (the catom prism) fill it;
// World (world.cpp) turns it into ODE objects.
// Trade-off: a closed set of shapes, joints and controllers keeps validation
// exhaustive and the model readable; new kinds are added here explicitly.
#pragma once
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

// The deterministic buggy driver: figure eights at varying speeds.
struct ControllerSpec {
    bool enabled = false;
    std::vector<int> steer_joints;  // hinge2 joints whose axis 1 steers
    std::vector<int> drive_joints;  // hinge2 joints whose axis 2 drives
    double steer_amplitude = 0.5;   // rad
    double period = 8.0;            // s per figure eight
    double speed_min = 5.0;         // wheel rad/s
    double speed_max = 15.0;
    double speed_period = 20.0;     // s per speed cycle
    double steer_gain = 10.0;
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

struct Scene {
    std::string name;
    std::string source;  // file it came from
    std::uint64_t seed = 1;
    int steps = 1000;
    double dt = 0.005;
    Vec3 gravity{0, 0, -9.81};
    int observe_every = 10;
    SolverSpec solver;
    std::vector<Material> materials;
    std::vector<BodySpec> bodies;  // index = global body id (and geom id)
    std::vector<StaticGeom> statics;
    std::vector<PlaneSpec> planes;
    std::vector<JointSpec> joints;
    MagnetModel magnets;
    ControllerSpec controller;
    GuardSpec guard;
    CheckSpec checks;

    std::size_t catom_count() const;
    bool any_magnets() const;
    int find_body(const std::string& name) const;
    int find_joint(const std::string& name) const;
};

}  // namespace parode
