// The contact solver's two row forms on the same contacts: sphere contacts as
// compact SphereRows and the same contacts as general Blocks (the solver's
// general-only mode) give the same motion to rounding, step after step, and a
// scene of spheres and boxes mixes both forms in one sweep. Four SIMD lanes
// give the bits of two. Each test states what it runs on: two worlds of one
// scene stepped side by side with the grid collider and the serial solver.
// Trade-off: worlds of a few hundred bodies and a few dozen steps, long enough
// for a wrong term in either form to show far above rounding (a lever arm or
// a tangent off by a sign moves the pile by centimetres within ten steps).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "grid_collide.hpp"
#include "register.hpp"
#include "solve/contact_solver.hpp"
#include "util/hash.hpp"
#include "test_support.hpp"

using namespace parode;

namespace {

// One world stepped by the project solver, with its own collider.
struct Stepper {
    World world;
    omp::GridBackend collide;
    ContactSolver solver;
    ContactBuffer contacts;
    Stepper(const Scene& sc, bool general_only) : world(sc, SpaceKind::Simple), solver(sc) {
        collide.set_geoms(world.space(), &world.geoms());
        solver.set_general_only(general_only);
    }
    void step(int max_contacts) {
        collide.collide(world.space(), max_contacts, contacts);
        solver.step(world, contacts);
    }
};

double max_velocity_gap(const World& a, const World& b) {
    double gap = 0;
    for (std::size_t i = 0; i < a.body_count(); ++i) {
        const dReal* va = dBodyGetLinearVel(a.body(i));
        const dReal* vb = dBodyGetLinearVel(b.body(i));
        const dReal* wa = dBodyGetAngularVel(a.body(i));
        const dReal* wb = dBodyGetAngularVel(b.body(i));
        for (int k = 0; k < 3; ++k) gap = std::max({gap, std::fabs(va[k] - vb[k]), std::fabs(wa[k] - wb[k])});
    }
    return gap;
}

double rms_position_gap(const World& a, const World& b) {
    double sum = 0;
    for (std::size_t i = 0; i < a.body_count(); ++i) {
        const dReal* x = dBodyGetPosition(a.body(i));
        const dReal* y = dBodyGetPosition(b.body(i));
        for (int k = 0; k < 3; ++k) sum += (x[k] - y[k]) * (x[k] - y[k]);
    }
    return std::sqrt(sum / static_cast<double>(a.body_count()));
}

double max_speed(const World& w) {
    double v = 0;
    for (std::size_t i = 0; i < w.body_count(); ++i) {
        const dReal* l = dBodyGetLinearVel(w.body(i));
        v = std::max(v, std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]));
    }
    return v;
}

TEST(ContactRows, SphereRowsAndGeneralBlocksGiveTheSameMotion) {
    omp::register_backends();
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=343"});
    Stepper rows(sc, false), blocks(sc, true);
    for (int s = 0; s < 40; ++s) {
        rows.step(sc.solver.max_contacts);
        blocks.step(sc.solver.max_contacts);
        ASSERT_EQ(rows.contacts.size(), blocks.contacts.size()) << "step " << s;
        EXPECT_EQ(rows.solver.general_blocks(), 0u);
        EXPECT_EQ(blocks.solver.sphere_rows(), 0u);
        if (s == 0) {
            EXPECT_GT(rows.solver.sphere_rows(), 300u) << "the prism's contacts";
            EXPECT_LT(max_velocity_gap(rows.world, blocks.world), 1e-9 * std::max(1.0, max_speed(blocks.world)));
        }
    }
    EXPECT_GT(rms_position_gap(rows.world, blocks.world), 0.0) << "the forms differ in rounding";
    EXPECT_LT(rms_position_gap(rows.world, blocks.world), 1e-6);
}

const char* kMixed = R"(
[scene]
name = "mixed"
dt = 0.005
[[materials]]
name = "m"
mu = 0.6
[[planes]]
normal = [0.0, 0.0, 1.0]
material = "m"
[[bodies]]
name = "box"
shape = "box"
size = [2.0, 2.0, 0.5]
position = [0.0, 0.0, 0.25]
material = "m"
[[bodies]]
name = "ball1"
radius = 0.5
position = [0.3, 0.0, 1.0]
material = "m"
[[bodies]]
name = "ball2"
radius = 0.5
position = [-0.7, 0.0, 1.0]
material = "m"
[[bodies]]
name = "ball3"
radius = 0.4
position = [3.0, 0.0, 0.4]
material = "m"
)";

TEST(ContactRows, SpheresAndBoxesMixBothFormsInOneSweep) {
    omp::register_backends();
    const Scene sc = load_scene_text(kMixed, "mixed");
    Stepper mixed(sc, false), blocks(sc, true);
    bool both = false;
    for (int s = 0; s < 300; ++s) {
        mixed.step(sc.solver.max_contacts);
        blocks.step(sc.solver.max_contacts);
        both = both || (mixed.solver.sphere_rows() > 0 && mixed.solver.general_blocks() > 0);
    }
    EXPECT_TRUE(both) << "ball-ball and ball-plane contacts as rows, box contacts as blocks";
    EXPECT_LT(rms_position_gap(mixed.world, blocks.world), 1e-6);
    for (std::size_t b : {1u, 2u}) EXPECT_NEAR(dBodyGetPosition(mixed.world.body(b))[2], 1.0, 0.02) << "ball " << b << " rests on the box";
    EXPECT_NEAR(dBodyGetPosition(mixed.world.body(3))[2], 0.4, 0.02) << "ball 3 rests on the floor";
}

TEST(ContactRows, FourLanesGiveTheBitsOfTwo) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=1000"});
    const bool had = four_lanes();
    set_four_lanes(false);
    const std::string two = hex64(test::run(sc, 100, "grid", 1, "pgs")->last().state_hash);
    set_four_lanes(true);
    const std::string four = hex64(test::run(sc, 100, "grid", 1, "pgs")->last().state_hash);
    set_four_lanes(had);
    EXPECT_EQ(two, four) << (four_lanes() ? "AVX lanes" : "no AVX here: both ran on two lanes");
}

}  // namespace
