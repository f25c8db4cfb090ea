// Bounds on the magnitudes a scene may give, so that every value reaching ODE
// is one it can represent and integrate. Outside them ODE stops on one of its
// internal assertions (abort) or the run turns into NaN within a few steps; the
// reader rejects such scenes with the file, line and key instead. The README's
// scene reference lists the same bounds.
// Trade-off: fixed, generous bounds rather than scene-dependent ones (only the
// speeds depend on dt): a scene inside them can still be physically poor (a
// 1e6 mass ratio converges slowly), but never numerically impossible.
#pragma once

#include "scene/scene.hpp"
#include "scene/toml_reader.hpp"

namespace parode::limits {

// Coordinates (positions, catom base, joint anchors, plane offsets): |x| <= 1e6 m.
// At 1e6 m a double still resolves 1.2e-10 m, a millionth of the smallest body
// allowed below; squared distances (1e12 m^2) stay far from overflow; and ODE's
// hash space, which turns coordinates into 32-bit cell indices (cells of 1/8 m
// at its finest level: 2.7e8 m), keeps a margin of 270 for bodies to travel.
constexpr double kMaxCoordinate = 1e6;

// Sizes (radius, length, box sides) and catom spacing: 1e-4 m to 1e4 m. Below
// 0.1 mm the coordinate resolution above and ODE's contact layer (1 mm by
// default) swamp the body; above 10 km a body reaches past the coordinate bound.
constexpr double kMinSize = 1e-4;
constexpr double kMaxSize = 1e4;

// Masses: 1e-6 kg to 1e6 kg each, and the heaviest dynamic body at most 1e6
// times the lightest. The contact solver's effective masses then span at most
// 1e6, which double precision (relative 1e-16) still resolves to 1e-10; mass
// 1e300 overflows ODE's inertia products at once. (Ratios past 1e3 already need
// many solver iterations: see the mass-ratio hard case.)
constexpr double kMinMass = 1e-6;
constexpr double kMaxMass = 1e6;
constexpr double kMaxMassRatio = 1e6;

// Speeds, tied to the time step: a body may move at most 10 m per step
// (|v| dt <= 10 m: 2,000 m/s at the default dt of 5 ms) and turn at most one
// revolution per step (|w| dt <= 2 pi). Past a revolution per step the
// rotation is aliased (2 pi + x looks like x) and ODE's quaternion update is
// meaningless; a body that moves further than its size per step already passes
// through others (tunnelling), and 1e200 m/s reaches coordinates ODE cannot
// index in one step. Motor target speeds (joint `vel`, controller speeds) are
// bounded by |w| <= 1e4 rad/s (about 95,000 rpm) whatever the dt: the motor's
// force limit, not its target, sets how fast the body actually turns.
constexpr double kMaxStepTravel = 10;
constexpr double kMaxStepTurn = 6.283185307179586;
constexpr double kMaxMotorSpeed = 1e4;

// Gravity: |g| <= 1e3 m/s^2, about 100 times the Earth's. 9.2e18 m/s^2 moves
// a body out of ODE's coordinate range in the first step.
constexpr double kMaxGravity = 1e3;

// The run guard stops a body faster than the speed bound (guard.max_speed
// defaults to it and may only be lower), so a run that explodes stops with
// exit 1 before its bodies leave the coordinates ODE can index.

// Joint parameters (scene name without its 2/3 axis suffix): ERPs, bounce and
// fudge factor in [0, 1] as ODE defines them; CFMs in [0, 1] like the world's
// (a negative CFM makes ODE's system indefinite; suspension_erp = 1e7 made the
// buggy's wheels leave ODE's range within 5 steps); fmax >= 0; motor speeds
// within kMaxMotorSpeed; stops any finite angle.
struct Range {
    double lo, hi;
};
Range joint_param_range(const std::string& name);

// Largest linear and angular speed (m/s, rad/s) allowed at time step dt.
inline double max_speed(double dt) { return kMaxStepTravel / dt; }
inline double max_turn_rate(double dt) { return kMaxStepTurn / dt; }

// "an array of 3 numbers, each in [-1e+06, 1e+06] (m)" and similar texts.
std::string coordinate_text();
std::string speed_text(double dt);
std::string turn_rate_text(double dt);

// Checks across bodies, after every body (catoms included) is read:
// dynamic masses within kMaxMassRatio of each other, every generated catom
// inside the coordinate bound. `root` locates the key to report.
void check_mass_ratio(const Node& root, const Scene& sc, std::size_t hand_written);
void check_catom_extent(const Node& root, const Scene& sc, std::size_t hand_written);

}  // namespace parode::limits
