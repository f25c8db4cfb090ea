// One execution context per pipeline: two pipelines in one process, with
// different thread counts and stepped in turns, each give the state hash they
// give alone, and neither sees the other's threads, crossovers or sharing
// verdicts. One pair runs ODE's QuickStep, whose reordering draws from ODE's
// process-global dRand: each World keeps its own seed (world.hpp), so turns do
// not interleave the two sequences. The registry's names and aliases resolve
// to the same implementations.
// Trade-off: small scenes (a few hundred catoms) with every loop threaded
// (min_parallel 0), so the threaded paths run while the test stays short.
#include <gtest/gtest.h>

#include "omp/stages.hpp"
#include "test_support.hpp"
#include "util/hash.hpp"

using namespace parode;

namespace {

struct Config {
    std::string scene, collide, solver;
    std::vector<std::string> sets;
    int threads;
};

RunOptions options_of(const Config& s) {
    RunOptions opt;
    opt.collide = s.collide;
    opt.solver = s.solver;
    opt.execution.threads = s.threads;
    opt.execution.min_parallel = 0;
    return opt;
}

std::string alone(const Config& s, int steps) {
    const Scene sc = test::repo_scene(s.scene, s.sets);
    Pipeline p(sc, options_of(s));
    for (int k = 0; k < steps; ++k) p.step();
    p.finish();
    return hex64(p.last().state_hash);
}

// Both pipelines built first, then stepped in turns.
std::pair<std::string, std::string> in_turns(const Config& a, const Config& b, int steps) {
    const Scene sa = test::repo_scene(a.scene, a.sets), sb = test::repo_scene(b.scene, b.sets);
    Pipeline pa(sa, options_of(a)), pb(sb, options_of(b));
    EXPECT_EQ(pa.execution().threads(), a.threads);
    EXPECT_EQ(pb.execution().threads(), b.threads);
    for (int k = 0; k < steps; ++k) {
        pa.step();
        pb.step();
    }
    pa.finish();
    pb.finish();
    return {hex64(pa.last().state_hash), hex64(pb.last().state_hash)};
}

TEST(Execution, TwoPipelinesWithTheirOwnThreadsInTurnsGiveTheirOwnHashes) {
    omp::add_stages();
    const Config a{"jobs/scenes/tennis.toml", "grid", "parallel", {"catoms.count=600", "scene.seed=3"}, 1};
    const Config b{"jobs/scenes/magnetic-tennis.toml", "grid", "parallel", {"catoms.count=700", "scene.seed=8"}, 2};
    const std::string ha = alone(a, 40), hb = alone(b, 40);
    ASSERT_NE(ha, hb);
    const auto [ta, tb] = in_turns(a, b, 40);
    EXPECT_EQ(ta, ha) << "1-thread pipeline stepped in turns with a 2-thread one";
    EXPECT_EQ(tb, hb) << "2-thread pipeline stepped in turns with a 1-thread one";
}

TEST(Execution, QuickStepPipelinesInTurnsKeepTheirOwnRandomSequence) {
    omp::add_stages();
    const Config a{"jobs/scenes/tennis.toml", "grid", "ode", {"catoms.count=300", "scene.seed=5"}, 2};
    const Config b{"jobs/scenes/tennis.toml", "ode-hash", "ode", {"catoms.count=300", "scene.seed=6"}, 1};
    const std::string ha = alone(a, 30), hb = alone(b, 30);
    const auto [ta, tb] = in_turns(a, b, 30);
    EXPECT_EQ(ta, ha);
    EXPECT_EQ(tb, hb);
}

TEST(Execution, SharingVerdictsAndCrossoversBelongToOnePipeline) {
    omp::add_stages();
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=300"});
    RunOptions one = options_of({"", "grid", "parallel", {}, 2}), two = one;
    two.execution.min_parallel = -1;
    Pipeline pa(sc, one), pb(sc, two);
    pa.execution().team().verdict(true);
    EXPECT_TRUE(pa.execution().team().shared());
    EXPECT_FALSE(pb.execution().team().shared());
    EXPECT_EQ(pa.execution().loops().threads(100), 1) << "shared cores: one thread";
    EXPECT_EQ(pb.execution().loops().threads(100), 1) << "below the crossover";
    EXPECT_EQ(pb.execution().loops().threads(1 << 20), 2);
    EXPECT_EQ(pa.execution().loops_name(), "loops/omp");
}

TEST(Execution, RegistryAliasesNameTheSameStages) {
    omp::add_stages();
    const Stages& st = Stages::instance();
    EXPECT_EQ(st.solver.canonical("pgs/omp"), "parallel");
    EXPECT_EQ(st.collide.canonical("grid/omp"), "grid");
    EXPECT_EQ(Stages::threaded(st.forces, "magnets"), "magnets/omp");
    EXPECT_EQ(Stages::threaded(st.forces, "controller"), "controller");
    EXPECT_THROW(st.solver.canonical("pgs/mpi"), std::invalid_argument);
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=300"});
    RunOptions by_alias = options_of({"", "grid/omp", "pgs/omp", {}, 2});
    Pipeline p(sc, by_alias);
    EXPECT_EQ(p.solver().name(), "parallel");
    EXPECT_EQ(p.backend().name(), "grid");
    for (int k = 0; k < 10; ++k) p.step();
    p.finish();
    EXPECT_EQ(hex64(p.last().state_hash), alone({"jobs/scenes/tennis.toml", "grid", "parallel", {"catoms.count=300"}, 1}, 10));
}

}  // namespace

// The sharing rule scales with the team: the waits measured on an idle
// 16-core virtual machine at 10^6 catoms (0.38 ms of work, 1.7 ms waited at a
// colour barrier; over the call 19.6 ms of work, 20.6 ms waited) are ordinary
// for 16 threads, while the same figures on 2 threads mean a core is taken;
// a thread descheduled for a time slice at every colour means one on 16 too.
TEST(Team, SharingRuleScalesWithTheTeam) {
    EXPECT_FALSE(barrier_says_shared(0.38e-3, 1.7e-3, 19.6e-3, 20.6e-3, 16));
    EXPECT_TRUE(barrier_says_shared(0.38e-3, 1.7e-3, 19.6e-3, 20.6e-3, 2));
    EXPECT_TRUE(barrier_says_shared(0.4e-3, 8e-3, 4e-3, 80e-3, 16));
    EXPECT_FALSE(barrier_says_shared(0.4e-3, 0.9e-3, 0.4e-3, 0.9e-3, 2));  // under 1 ms: a slow wake-up
    EXPECT_FALSE(barrier_says_shared(0.4e-3, 8e-3, 4e-3, 80e-3, 1));        // one thread waits for no one
}
