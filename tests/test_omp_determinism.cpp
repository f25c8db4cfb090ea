// Thread-count independence of the OpenMP stages: after 200 steps of tennis and
// magnetic-tennis (1,000 catoms), the grid backend on 1, 2, 3 and 4 threads
// (with the parallel magnet pass) gives the state hash of ODE's hash space.
// When the stages use their threads never changes a result: below the size
// crossovers, or with the team's cores shared, they run on one thread and
// give the same bits; and the sharing policy backs off 1, 2, 4 ... 16 steps.
// The observation's contact figures (count, deepest, mean depth) equal those
// taken serially from the contact buffer, on any thread count.
// Trade-off: whole-pipeline hashes catch any difference anywhere in the step;
// the contact-level comparisons live in tests/omp/.
#include <gtest/gtest.h>

#include <cstring>

#include "forces/magnets.hpp"
#include "omp/forces/magnet_pass.hpp"
#include "omp/grid/geom_info.hpp"
#include "observe/diagnostics.hpp"
#include "scene/scene_file.hpp"
#include "util/exact_sum.hpp"
#include "util/hash.hpp"
#include "omp/stages.hpp"

#include "test_support.hpp"

using namespace parode;

namespace {

class ThreadCounts : public ::testing::TestWithParam<const char*> {};

TEST_P(ThreadCounts, GridOnOneToFourThreadsMatchesOdeHashSpace) {
    const Scene sc = test::repo_scene(std::string("jobs/scenes/") + GetParam() + ".toml", {"catoms.count=1000"});
    const std::string reference = hex64(test::hash_after(sc, 200, "ode-hash", 1));
    for (int threads = 1; threads <= 4; ++threads) {
        EXPECT_EQ(hex64(test::hash_after(sc, 200, "grid", threads)), reference) << threads << " threads";
    }
}

INSTANTIATE_TEST_SUITE_P(Classic, ThreadCounts, ::testing::Values("tennis", "magnetic-tennis"));

TEST(ThreadCounts, ParallelMagnetGatherEqualsSerialGather) {
    Scene sc = test::repo_scene("jobs/scenes/magnetic-tennis.toml", {"catoms.count=343"});
    auto p = test::run(sc, 20, "ode-hash", 1);
    MagnetField field(sc);
    field.prepare(p->world());
    std::vector<BodyWrench> serial(field.members().size());
    for (std::size_t k = 0; k < serial.size(); ++k) serial[k] = field.gather(k);
    ASSERT_EQ(field.targets().size(), serial.size());  // one process: every member a target, in order
    for (int threads = 1; threads <= 4; ++threads) {
        ExecutionConfig config;
        config.threads = threads;
        config.min_parallel = 0;
        const auto exec = Stages::instance().execution(config);
        parode::omp::MagnetPassOmp pass(sc, *exec);
        const std::vector<BodyWrench>& par = pass.wrenches(p->world());
        ASSERT_EQ(par.size(), serial.size());
        for (std::size_t k = 0; k < serial.size(); ++k) {
            ASSERT_EQ(0, std::memcmp(&par[k], &serial[k], sizeof(BodyWrench))) << "body " << k << ", " << threads << " threads";
        }
    }
}

// Two [[bodies]] spheres of other radii before a few catoms.
const char* kMixedSpheres = R"(
[scene]
name = "mixed"
[[materials]]
name = "m"
[[bodies]]
name = "big"
shape = "sphere"
radius = 0.75
mass = 2.0
position = [0.0, 0.0, 3.0]
material = "m"
[[bodies]]
name = "small"
shape = "sphere"
radius = 0.125
mass = 0.5
position = [2.0, 0.0, 3.0]
material = "m"
[catoms]
count = 27
radius = 0.5
mass = 1.0
layout = "prism"
jitter = 0.01
material = "m"
)";

bool same_geom(const parode::omp::GeomFull& a, const parode::omp::GeomFull& b) {
    return std::memcmp(a.aabb, b.aabb, sizeof a.aabb) == 0 && a.body == b.body && a.category == b.category &&
           a.collide == b.collide && a.flags == b.flags && std::memcmp(&a.extent, &b.extent, sizeof a.extent) == 0 &&
           a.prim.geom == b.prim.geom && a.prim.id == b.prim.id && a.prim.flags == b.prim.flags &&
           std::memcmp(a.prim.p, b.prim.p, sizeof a.prim.p) == 0;
}

// What World tells the grid backend of its body geoms (World::sphere_bodies)
// is what reading each geom from ODE gives, for owned bodies and ghosts of
// three radii, also after a removal moves a body to another local index.
TEST(SphereBodies, WorldsHintEqualsReadingTheGeoms) {
    const Scene sc = load_scene_text(kMixedSpheres, "mixed.toml");
    World w(sc, SpaceKind::Simple);
    ASSERT_NE(w.sphere_bodies(), nullptr);
    w.set_ghost(1, true);
    w.set_ghost(5, true);
    w.remove_body(0);  // the last body moves to local 0
    ASSERT_TRUE(w.ghost(1) && w.ghost(5) && !w.ghost(0));
    ASSERT_EQ(w.gid(0), 28u);
    for (std::size_t i = 0; i < w.body_count(); ++i) {
        const parode::omp::GeomFull hinted = parode::omp::hinted_sphere(w.geoms()[i], *w.sphere_bodies(), i);
        EXPECT_TRUE(same_geom(hinted, parode::omp::read_geom(w.geoms()[i]))) << "body " << i << " (id " << w.gid(i) << ")";
    }
    const Scene buggy_scene = test::repo_scene("jobs/scenes/buggy.toml");
    const World buggy(buggy_scene, SpaceKind::Simple);
    EXPECT_EQ(buggy.sphere_bodies(), nullptr);  // a box among the bodies
}

// Tennis without joints: every contact counts.
TEST(ThreadCounts, ObservedContactFiguresEqualTheBuffersOwn) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=4000"});
    auto p = test::run(sc, 20, "grid", 1);
    const auto& items = p->contacts().items();
    ASSERT_GT(items.size(), 4096u);  // more than one chunk of the contact pass
    double deepest = 0;
    ExactSum sum;
    for (const ContactRecord& c : items) {
        deepest = std::max(deepest, c.geom.depth);
        sum.add(c.geom.depth);
    }
    const double mean = sum.value() / static_cast<double>(items.size());
    for (int threads = 1; threads <= 3; ++threads) {
        ExecutionConfig config;
        config.threads = threads;
        config.min_parallel = 0;
        const auto exec = Stages::instance().execution(config);
        const Diagnostics d = observe(p->world(), p->contacts(), p->collectives(), exec->loops());
        EXPECT_EQ(d.contacts, items.size()) << threads << " threads";
        EXPECT_EQ(d.max_penetration, deepest) << threads << " threads";
        EXPECT_EQ(d.mean_penetration, mean) << threads << " threads";
    }
}

}  // namespace

namespace {

// The parallel solver and grid on `threads` threads; `min_parallel` as
// ExecutionConfig::min_parallel; `shared`: the team told before every step
// that its cores are shared.
std::string hash_with(const Scene& sc, int steps, int threads, long min_parallel, bool shared) {
    parode::omp::add_stages();
    RunOptions opt;
    opt.collide = "grid";
    opt.solver = "parallel";
    opt.execution.threads = threads;
    opt.execution.min_parallel = min_parallel;
    Pipeline p(sc, opt);
    for (int s = 0; s < steps; ++s) {
        if (shared) p.execution().team().verdict(true);
        p.step();
    }
    p.finish();
    return hex64(p.last().state_hash);
}

TEST(Thresholds, SerialBelowTheCrossoverAndOnSharedCoresGiveTheThreadedBits) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=1000"});
    const std::string threaded = hash_with(sc, 100, 2, 0, false);
    EXPECT_EQ(hash_with(sc, 100, 2, 1L << 40, false), threaded) << "every stage below its crossover";
    EXPECT_EQ(hash_with(sc, 100, 2, 0, true), threaded) << "cores shared: one thread";
    EXPECT_EQ(hash_with(sc, 100, 1, 0, false), threaded);
}

TEST(Thresholds, SharedCoresBackOffOneTwoFourUpToSixteenSteps) {
    Team team(2, -1, true);
    EXPECT_TRUE(team.try_threads());
    std::vector<int> alone;
    for (int round = 0; round < 7; ++round) {
        team.verdict(true);  // this step's try failed
        team.end_step();
        int steps = 0;
        for (team.begin_step(); !team.try_threads(); team.begin_step()) {
            ++steps;
            team.end_step();
        }
        alone.push_back(steps);
    }
    EXPECT_EQ(alone, (std::vector<int>{1, 2, 4, 8, 16, 16, 16}));
    team.verdict(false);
    EXPECT_TRUE(team.try_threads());
    EXPECT_FALSE(team.shared());
}

}  // namespace
