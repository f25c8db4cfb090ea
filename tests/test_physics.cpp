// Physics against analytic results: free fall (exactly ODE's semi-implicit
// Euler, and the continuous parabola to first order in dt), a sphere rolling
// without slipping down an incline (a = 5/7 g sin(theta)), a resting column,
// magnetised vs plain catom pairs, and the buggy driving (its figure eights
// close on the start). Trade-off: scenes are small inline TOML so each test
// states exactly what it simulates; the buggy runs its repository scene.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "forces/controller.hpp"
#include "forces/magnets.hpp"
#include "test_support.hpp"

using namespace parode;
using parode::test::position;
using parode::test::velocity;

namespace {

const char* kFreeFall = R"(
[scene]
name = "free-fall"
steps = 100
dt = 0.01
gravity = [0.0, 0.0, -9.81]
[[bodies]]
name = "ball"
radius = 0.1
position = [0.0, 0.0, 100.0]
)";

TEST(Physics, FreeFallMatchesSemiImplicitEulerAndParabola) {
    const Scene sc = load_scene_text(kFreeFall, "free-fall");
    const int n = 100;
    auto p = test::run(sc, n);
    const double g = 9.81, dt = 0.01, t = n * dt;
    const double z_discrete = 100.0 - g * dt * dt * n * (n + 1) / 2.0;
    EXPECT_NEAR(position(*p, 0)[2], z_discrete, 1e-9);
    EXPECT_NEAR(velocity(*p, 0)[2], -g * t, 1e-9);
    // Continuous solution z0 - g t^2 / 2, to within the O(dt) error g t dt / 2.
    EXPECT_NEAR(position(*p, 0)[2], 100.0 - 0.5 * g * t * t, 0.5 * g * t * dt * 1.01);
    EXPECT_EQ(position(*p, 0)[0], 0.0);
}

std::string incline_scene(double theta) {
    const double s = std::sin(theta), c = std::cos(theta), r = 0.5;
    return "[scene]\nname = \"incline\"\ndt = 0.001\n"
           "[[materials]]\nname = \"grip\"\nmu = 1.0\n"
           "[[planes]]\nnormal = [" + std::to_string(s) + ", 0.0, " + std::to_string(c) + "]\nmaterial = \"grip\"\n"
           "[[bodies]]\nname = \"ball\"\nradius = 0.5\nmaterial = \"grip\"\nposition = [" +
           std::to_string(r * s) + ", 0.0, " + std::to_string(r * c) + "]\n";
}

TEST(Physics, SphereRollsDownInclineAtFiveSeventhsGSinTheta) {
    const double theta = 0.3;
    const Scene sc = load_scene_text(incline_scene(theta), "incline");
    const int n = 1000;
    auto p = test::run(sc, n);
    const Vec3 v = velocity(*p, 0);
    const double along = v[0] * std::cos(theta) - v[2] * std::sin(theta);  // down-slope direction
    const double a = along / (n * sc.dt);
    const double expected = 5.0 / 7.0 * 9.81 * std::sin(theta);
    EXPECT_NEAR(a, expected, 0.02 * expected) << "measured " << a << " m/s^2";
    // Rolling without slipping: contact-point speed ~ 0, i.e. |w| r = |v|.
    const dReal* w = dBodyGetAngularVel(p->world().body(0));
    EXPECT_NEAR(std::fabs(w[1]) * 0.5, std::fabs(along), 0.02 * std::fabs(along));
}

std::string column_scene(int n) {
    std::string s = "[scene]\nname = \"column\"\ndt = 0.005\n[[planes]]\nnormal = [0.0, 0.0, 1.0]\n";
    for (int i = 0; i < n; ++i) {
        s += "[[bodies]]\nname = \"b" + std::to_string(i) + "\"\nradius = 0.5\nposition = [0.0, 0.0, " +
             std::to_string(0.5 + i) + "]\n";
    }
    return s;
}

TEST(Physics, RestingColumnStaysUp) {
    const int n = 6;
    const Scene sc = load_scene_text(column_scene(n), "column");
    auto p = test::run(sc, 1000);
    const Vec3 top = position(*p, n - 1);
    EXPECT_NEAR(top[2], 0.5 + (n - 1), 0.02);
    EXPECT_LT(std::hypot(top[0], top[1]), 1e-6);
    EXPECT_LT(p->last().kinetic, 1e-3);
}

// Two catoms: a at x = 0 (velocity va), b at x = 1 + gap (velocity vb), in
// zero gravity, magnets on or off.
Scene catom_pair(bool magnets, double va, double vb, double gap, double shear) {
    std::ostringstream text;
    text << "[scene]\nname = \"pair\"\ndt = 0.005\ngravity = [0.0, 0.0, 0.0]\n"
         << "[[bodies]]\nname = \"a\"\ncatom = true\nvelocity = [" << va << ", 0.0, 0.0]\n"
         << "[[bodies]]\nname = \"b\"\ncatom = true\nposition = [" << 1.0 + gap << ", " << shear
         << ", 0.0]\nvelocity = [" << vb << ", 0.0, 0.0]\n"
         << "[magnets]\nenabled = " << (magnets ? "true" : "false") << "\n";
    return load_scene_text(text.str(), "pair");
}

// Two touching catoms pushed apart at 1 m/s each, in zero gravity.
double pair_separation(bool magnets) {
    const Scene sc = catom_pair(magnets, -1.0, 1.0, 0.0, 0.0);
    auto p = test::run(sc, 400);
    const Vec3 a = position(*p, 0), b = position(*p, 1);
    return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

TEST(Physics, MagnetisedCatomsStayTogetherPlainOnesDoNot) {
    EXPECT_LT(pair_separation(true), 1.05);   // touching distance is 1.0
    EXPECT_GT(pair_separation(false), 4.0);   // 1.0 + 2 m/s * 2 s
}

TEST(Physics, MagnetForcesAreEqualAndOpposite) {
    // slightly apart (net attraction) and sheared
    const Scene sc = catom_pair(true, 0.0, 0.0, 0.03, 0.01);
    World w(sc, SpaceKind::Simple);
    MagnetField field(sc);
    field.prepare(w);
    const BodyWrench a = field.gather(0), b = field.gather(1);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a.force[c], -b.force[c], 1e-9);
    EXPECT_GT(a.force[0], 0.0);  // body 0 is pulled towards body 1 (+x)
}

TEST(Physics, BuggyDrivesForwardTurnsAndStaysUpright) {
    const Scene sc = test::repo_scene("jobs/scenes/buggy.toml");
    RunOptions opt;
    Pipeline p(sc, opt);
    double min_up = 1, max_dist = 0, yaw_min = 0, yaw_max = 0, yaw_prev = 0, yaw_unwrapped = 0;
    for (int s = 0; s < 1500; ++s) {
        p.step();
        const dReal* R = dBodyGetRotation(p.world().body(0));
        min_up = std::min(min_up, static_cast<double>(R[10]));  // body z . world z
        const Vec3 x = position(p, 0);
        max_dist = std::max(max_dist, std::hypot(x[0], x[1]));
        double yaw = std::atan2(R[4], R[0]), d = yaw - yaw_prev;
        d -= 2 * M_PI * std::round(d / (2 * M_PI));
        yaw_unwrapped += d;
        yaw_prev = yaw;
        yaw_min = std::min(yaw_min, yaw_unwrapped);
        yaw_max = std::max(yaw_max, yaw_unwrapped);
        if (s == 100) {
            EXPECT_GT(x[0], 0.5) << "the buggy should first drive forward (+x)";
        }
    }
    EXPECT_GT(min_up, 0.8) << "the chassis tipped over";
    EXPECT_GT(max_dist, 3.0);
    EXPECT_GT(yaw_max - yaw_min, M_PI) << "the buggy should turn";
}

// The buggy's figure eights close: at the end of each half eight of the
// schedule (the crossing, then the end of the eight) the chassis is back within
// 0.5 m of its start (measured: 0.1 m), after going round a circle of 2R = 5 m
// across, the left one (+y) first; three eights, 64 s simulated. A constant
// steering angle or an open-loop schedule misses the start by metres.
TEST(Physics, BuggyFigureEightsReturnToTheStart) {
    const Scene sc = test::repo_scene("jobs/scenes/buggy.toml");
    const ControllerSpec& c = sc.controller;
    RunOptions opt;
    Pipeline p(sc, opt);
    const auto chassis = static_cast<std::size_t>(c.chassis);
    int step = 0;
    for (int half = 1; half <= 6; ++half) {
        const double side = half % 2 ? 1.0 : -1.0;  // left circle (+y), then right circle (-y)
        const int end = static_cast<int>(std::llround(time_at_distance(c, half * 0.5 * eight_length(c)) / sc.dt));
        double across = 0;
        for (; step < end; ++step) {
            p.step();
            across = std::max(across, side * (position(p, chassis)[1] - c.start[1]));
        }
        const Vec3 x = position(p, chassis);
        EXPECT_LT(std::hypot(x[0] - c.start[0], x[1] - c.start[1]), 0.5) << "half eight " << half << " at step " << end;
        EXPECT_GT(across, 0.9 * 2 * c.radius) << "half eight " << half << ": the circle was not driven round";
    }
}

}  // namespace
