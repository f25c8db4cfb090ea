// Physics against analytic results: free fall (exactly ODE's semi-implicit
// Euler, and the continuous parabola to first order in dt), a sphere rolling
// without slipping down an incline (a = 5/7 g sin(theta)), a resting column,
// magnetised vs plain catom pairs, and the buggy driving (its figure eights
// close on the start). Trade-off: scenes are small inline TOML so each test
// states exactly what it simulates; the buggy runs its repository scene.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
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

// A loose cloud of side^3 catoms at random orientations, 1.0 to 1.3 m apart.
Scene magnet_cloud(int side) {
    std::ostringstream text;
    text << "[scene]\nname = \"cloud\"\ndt = 0.005\ngravity = [0.0, 0.0, 0.0]\n";
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int i = 0; i < side * side * side; ++i) {
        const double x = (i % side) * 1.15 + 0.15 * u(rng), y = (i / side % side) * 1.15 + 0.15 * u(rng),
                     z = (i / (side * side)) * 1.15 + 0.15 * u(rng);
        text << "[[bodies]]\nname = \"c" << i << "\"\ncatom = true\nposition = [" << x << ", " << y << ", " << z
             << "]\nrotation = {axis = [" << u(rng) << ", " << u(rng) << ", 1.0], angle = " << 3 * u(rng) << "}\n";
    }
    text << "[magnets]\nenabled = true\ncutoff = 0.45\n";
    return load_scene_text(text.str(), "cloud");
}

// Body i's wrench summed over every pole pair of the scene within the cutoff
// (no cells nor pruning); `pairs` counts the pairs.
BodyWrench every_pole_pair(const Scene& sc, const World& w, std::size_t i, int& pairs) {
    const MagnetModel& mm = sc.magnets;
    auto pole = [&](std::size_t b, std::size_t a) {
        const dReal* p = dBodyGetPosition(w.body(b));
        const dReal* R = dBodyGetRotation(w.body(b));
        const Vec3& d = mm.directions[a];
        const double r = sc.bodies[b].shape.radius;
        return Vec3{p[0] + r * (R[0] * d[0] + R[1] * d[1] + R[2] * d[2]), p[1] + r * (R[4] * d[0] + R[5] * d[1] + R[6] * d[2]),
                    p[2] + r * (R[8] * d[0] + R[9] * d[1] + R[10] * d[2])};
    };
    BodyWrench out;
    const dReal* c = dBodyGetPosition(w.body(i));
    for (std::size_t j = 0; j < w.body_count(); ++j) {
        for (std::size_t a = 0; a < mm.directions.size() && j != i; ++a) {
            for (std::size_t b = 0; b < mm.directions.size(); ++b) {
                const Vec3 pa = pole(i, a), pb = pole(j, b);
                const double d[3] = {pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]};
                const double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                if (r2 >= mm.cutoff * mm.cutoff) continue;
                ++pairs;
                const double s = r2 + mm.softening * mm.softening, taper = (1 - r2 / (mm.cutoff * mm.cutoff));
                const double k = mm.strength * mm.charges[a] * mm.charges[b] * taper * taper / (s * std::sqrt(s));
                const double F[3] = {k * d[0], k * d[1], k * d[2]}, arm[3] = {pa[0] - c[0], pa[1] - c[1], pa[2] - c[2]};
                for (int e = 0; e < 3; ++e) out.force[e] += F[e];
                out.torque[0] += arm[1] * F[2] - arm[2] * F[1];
                out.torque[1] += arm[2] * F[0] - arm[0] * F[2];
                out.torque[2] += arm[0] * F[1] - arm[1] * F[0];
            }
        }
    }
    return out;
}

// Every body's gathered wrench equals every_pole_pair's, to rounding; returns
// the pole pairs counted.
int expect_every_pole_pair(const Scene& sc, const World& w, const MagnetField& field, const char* what) {
    int pairs = 0;
    for (std::size_t i = 0; i < w.body_count(); ++i) {
        const BodyWrench f = every_pole_pair(sc, w, i, pairs), g = field.gather(i);
        for (int e = 0; e < 3; ++e) {
            EXPECT_NEAR(g.force[e], f.force[e], 1e-9 * (1 + std::fabs(f.force[e]))) << what << ", body " << i;
            EXPECT_NEAR(g.torque[e], f.torque[e], 1e-9 * (1 + std::fabs(f.torque[e]))) << what << ", body " << i;
        }
    }
    return pairs;
}

// 27 catoms: every body's gathered wrench equals the sum over every pole pair
// of the scene within the cutoff, to rounding. Many pole pairs lie anywhere
// in the cutoff here, unlike in a settled lattice.
TEST(Physics, MagnetGatherEqualsEveryPolePairSummed) {
    const Scene sc = magnet_cloud(3);
    World w(sc, SpaceKind::Simple);
    MagnetField field(sc);
    field.prepare(w);
    const int pairs = expect_every_pole_pair(sc, w, field, "cloud");
    EXPECT_GT(pairs, 40) << "the cloud must put many pole pairs inside the cutoff (each counted from both sides)";
}

// The same field prepared again after its bodies moved (a few by half a
// cell: the cell list sorted from last step's order by insertion; every body
// to another's place: by std::sort) still gathers every pole pair.
TEST(Physics, MagnetCellListFollowsMovedBodies) {
    const Scene sc = magnet_cloud(5);
    World w(sc, SpaceKind::Simple);
    MagnetField field(sc);
    field.prepare(w);
    for (std::size_t i = 0; i < w.body_count(); i += 7) {
        const dReal* p = dBodyGetPosition(w.body(i));
        dBodySetPosition(w.body(i), p[0] + 0.5 * field.reach(), p[1] - 0.5 * field.reach(), p[2]);
    }
    field.prepare(w);
    expect_every_pole_pair(sc, w, field, "a few moved");
    std::vector<std::size_t> order(w.body_count());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::shuffle(order.begin(), order.end(), std::mt19937(3));
    std::vector<Vec3> at(w.body_count());
    for (std::size_t i = 0; i < at.size(); ++i) {
        const dReal* p = dBodyGetPosition(w.body(order[i]));
        at[i] = {p[0], p[1], p[2]};
    }
    for (std::size_t i = 0; i < at.size(); ++i) dBodySetPosition(w.body(i), at[i][0], at[i][1], at[i][2]);
    field.prepare(w);
    expect_every_pole_pair(sc, w, field, "every body moved");
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
