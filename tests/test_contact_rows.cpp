// The contact solver's two row forms on the same contacts: sphere contacts as
// compact SphereRows and the same contacts as general Blocks (the solver's
// general-only mode) give the same motion to rounding, step after step, and a
// scene of spheres and boxes mixes both forms in one sweep; one contact
// between unequal balls, built both ways, has the same effective masses.
// Four SIMD lanes give the bits of two. Each test states what it runs on:
// mostly two worlds of one scene stepped side by side with the grid collider
// and the serial solver.
// Trade-off: worlds of a few hundred bodies and a few dozen steps, long enough
// for a wrong term in either form to show far above rounding (a lever arm or
// a tangent off by a sign moves the pile by centimetres within ten steps);
// the tennis catoms are all alike, so the effective masses of unequal bodies
// are checked on one contact directly.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "omp/grid/grid_collide.hpp"
#include "omp/stages.hpp"
#include "solve/contact_solver.hpp"
#include "util/hash.hpp"
#include "test_support.hpp"

using namespace parode;

namespace {

// One world stepped by the project solver, with its own collider.
struct Stepper {
    std::unique_ptr<Execution> exec = Stages::instance().execution({});
    World world;
    omp::GridBackend collide;
    ContactSolver solver;
    ContactBuffer contacts;
    Stepper(const Scene& sc, bool general_only) : world(sc, SpaceKind::Simple), collide(*exec), solver(sc, *exec) {
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
    omp::add_stages();
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
    omp::add_stages();
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

// One contact between balls of unequal mass and inertia (radii 0.5 and 0.3),
// built both ways: the sphere row's effective masses (SOR w over
// J inv(M) J^T + CFM) are the general block's to rounding. The block's are
// read back from its CFM, which it stores scaled by them. PGS reaches the
// same impulses with a wrong effective mass, only slower, so a small scene
// would not show one; this compares the numbers themselves.
TEST(ContactRows, SphereRowEffectiveMassesAreTheBlocks) {
    const double unit[3] = {0.3, -0.2, std::sqrt(1.0 - 0.3 * 0.3 - 0.2 * 0.2)};
    ContactFrame f{};
    f.b1 = 0;
    f.b2 = 1;
    f.depth = 0.01;
    for (int i = 0; i < 3; ++i) {
        f.n[i] = unit[i];
        f.c1[i] = -(0.5 - f.depth / 2) * unit[i];  // contact point from body 1's centre
        f.c2[i] = (0.3 - f.depth / 2) * unit[i];   // and from body 2's
    }
    const double zero[6] = {0, 0, 0, 0, 0, 0};
    const double invm[2] = {2.0, 9.0}, invi[2] = {20.0, 250.0};
    double invI[2][9] = {};
    dSurfaceParameters surface{};
    surface.mu = 0.6;
    RowInputs in{};
    for (int j = 0; j < 2; ++j) {
        in.tmp[j] = zero;
        in.vel[j] = zero;
        in.invm[j] = invm[j];
        in.invi[j] = invi[j];
        invI[j][0] = invI[j][4] = invI[j][8] = invi[j];
        in.invI[j] = invI[j];
    }
    in.surface = &surface;
    in.fps = 200;
    in.erp = 0.2;
    in.cfm = 1e-5;
    in.max_correcting_vel = 1e9;
    in.sor_w = 1.3;
    SphereRow row{};
    Block block{};
    build_sphere_row(f, in, row);
    build_block(f, in, block);
    ASSERT_EQ(block.rows, 3);
    const double cf = in.cfm * in.fps;
    BodyRow B[2] = {};
    for (int j = 0; j < 2; ++j) {
        B[j].invm = invm[j];
        B[j].invi = invi[j];
    }
    double ad_n = 0, ad_t = 0;
    sphere_row_masses(row, B[0], B[1], SphereRowConstants{in.sor_w, cf}, ad_n, ad_t);
    // What the build keeps is what the relaxation would compute, bit for bit.
    EXPECT_EQ(row.ad_n, ad_n);
    EXPECT_EQ(row.ad_t, ad_t);
    EXPECT_EQ(row.kt, 1.0 / std::sqrt(row.n[2] * row.n[2] > 0.5 ? row.n[1] * row.n[1] + row.n[2] * row.n[2]
                                                                   : row.n[0] * row.n[0] + row.n[1] * row.n[1]));
    const double ad[3] = {ad_n, ad_t, ad_t};
    for (int r = 0; r < 3; ++r) {
        const double block_ad = block.cfm[r] / cf;
        EXPECT_NEAR(ad[r], block_ad, 1e-12 * block_ad) << "row " << r;
    }
}

TEST(ContactRows, FourLanesGiveTheBitsOfTwo) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=1000"});
    const bool had = four_lanes(), had_eight = eight_lanes();
    set_eight_lanes(false);  // four streams of packs of four (or two pairs)
    set_four_lanes(false);
    const std::string two = hex64(test::run(sc, 100, "grid", 1, "pgs")->last().state_hash);
    set_four_lanes(true);
    const std::string four = hex64(test::run(sc, 100, "grid", 1, "pgs")->last().state_hash);
    set_four_lanes(had);
    set_eight_lanes(had_eight);
    EXPECT_EQ(two, four) << (four_lanes() ? "AVX lanes" : "no AVX here: both ran on two lanes");
}

// Eight lanes (AVX-512) against four: eight streams of cells a colour packed
// eight at a time, or four packed four at a time, relax the same contacts in
// another grouping; each body must still see the same arithmetic.
TEST(ContactRows, EightLanesGiveTheBitsOfFour) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=1000"});
    const bool had = eight_lanes();
    set_eight_lanes(false);
    const std::string four = hex64(test::run(sc, 100, "grid", 1, "pgs")->last().state_hash);
    set_eight_lanes(true);
    const std::string eight = hex64(test::run(sc, 100, "grid", 1, "pgs")->last().state_hash);
    set_eight_lanes(had);
    EXPECT_EQ(four, eight) << (eight_lanes() ? "AVX-512 lanes" : "no AVX-512 here: both ran on four lanes");
}

}  // namespace
