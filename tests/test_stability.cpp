// Stability suite: every hard case of jobs/scenes/hard/ passes its own [checks]
// (no NaN, no runaway energy, bounded penetration, what should stand stands),
// and each criterion can fail: the same case pushed past its stability limit
// (larger dt, fewer iterations; see analysis/results/stability_map.md) must be
// reported as failing. Also the guard: a non-finite state stops the run at the
// step it appears, naming the body, and writes the last good state.
// Trade-off: each case runs its full scene (a few seconds of simulated time on
// at most a few hundred bodies, ~5 s for the whole file); the 100,000-catom
// pile is in test_stability_longrun.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "test_support.hpp"

using namespace parode;

namespace {

struct Verdict {
    bool passed = false;
    std::string why;  // failed items or the guard's message
};

// Runs a hard case for its own simulated duration (scene.steps x scene.dt),
// whatever dt the overrides set, as jobs/stability_map.py does.
Verdict run_case(const std::string& name, const std::vector<std::string>& sets = {}, const std::string& solver = "") {
    const std::string file = "jobs/scenes/hard/" + name + ".toml";
    const Scene base = test::repo_scene(file);
    const Scene sc = test::repo_scene(file, sets);
    const int steps = static_cast<int>(std::llround(base.steps * base.dt / sc.dt));
    Verdict v;
    try {
        auto p = solver.empty() ? test::run(sc, steps) : test::run(sc, steps, "grid", 1, solver);
        const nlohmann::json r = p->checks_result();
        v.passed = r.at("passed").get<bool>();
        v.why = r.dump();
    } catch (const SimulationError& e) {
        v.why = e.what();
    }
    return v;
}

void expect_pass(const std::string& name) {
    const Verdict v = run_case(name);
    EXPECT_TRUE(v.passed) << name << ": " << v.why;
}

void expect_fail(const std::string& name, const std::vector<std::string>& sets) {
    const Verdict v = run_case(name, sets);
    EXPECT_FALSE(v.passed) << name << " should fail with " << sets.front() << ": " << v.why;
}

TEST(Stability, ColumnOf32Stands) { expect_pass("column"); }
TEST(Stability, ColumnSinksAtFourTimesItsDt) { expect_fail("column", {"scene.dt=0.02"}); }
TEST(Stability, ColumnSinksWithTwoIterations) { expect_fail("column", {"solver.iterations=2"}); }

TEST(Stability, ClosePackedPyramidStands) { expect_pass("pyramid"); }
TEST(Stability, PyramidSlidesApartAtEightTimesItsDt) { expect_fail("pyramid", {"scene.dt=0.04"}); }

TEST(Stability, HeavyCatomOnLightOnesIsCarried) { expect_pass("mass-ratio"); }
TEST(Stability, MassRatioSinksWithTwentyIterations) { expect_fail("mass-ratio", {"solver.iterations=20"}); }

TEST(Stability, FastCatomDoesNotTunnel) { expect_pass("fast-catom"); }
TEST(Stability, FastCatomIsPushedThroughTheBaseWithTenIterations) {
    expect_fail("fast-catom", {"solver.iterations=10"});
}

TEST(Stability, OverlapResolvesWithoutExplosion) { expect_pass("overlap"); }
TEST(Stability, OverlapFailsAtSixteenTimesItsDt) { expect_fail("overlap", {"scene.dt=0.08"}); }

TEST(Stability, MagneticLatticeHolds) { expect_pass("magnetic-lattice"); }
TEST(Stability, MagneticLatticeFliesApartAtLargeDt) { expect_fail("magnetic-lattice", {"scene.dt=0.01"}); }

TEST(Stability, BuggyCrossesTheRampAtSpeed) { expect_pass("buggy-fast"); }
TEST(Stability, BuggyFailsAtEightTimesItsDt) { expect_fail("buggy-fast", {"scene.dt=0.08"}); }

TEST(Stability, PileRestsTenSecondsAndSleeps) { expect_pass("resting-pile"); }
TEST(Stability, RestingPileNeverSleepsWithFiveIterations) { expect_fail("resting-pile", {"solver.iterations=5"}); }

// The adaptive solver passes every hard case parode's contact solver runs,
// with its own defaults (8 sweeps of every cell, whatever iterations the
// scene gives QuickStep); without its sweeps of the cells still changing
// (solver.extra_sweeps = 0: 8 sweeps) the fast catom goes through the base.
class AdaptiveStability : public ::testing::TestWithParam<const char*> {};
TEST_P(AdaptiveStability, PassesItsChecks) {
    const Verdict v = run_case(GetParam(), {}, "adaptive/omp");
    EXPECT_TRUE(v.passed) << GetParam() << ": " << v.why;
}
INSTANTIATE_TEST_SUITE_P(HardCases, AdaptiveStability, ::testing::ValuesIn(test::kContactHardCases),
                         [](const ::testing::TestParamInfo<const char*>& p) { return test::param_name(p.param); });
TEST(Stability, FastCatomTunnelsWithoutTheAdaptiveSolversExtraSweeps) {
    const Verdict v = run_case("fast-catom", {"solver.extra_sweeps=0"}, "adaptive/omp");
    EXPECT_FALSE(v.passed) << v.why;
}

// A non-finite velocity stops the run at the next step, naming the body, and
// the last good state (step 0) is written out. (Bodies out of contact: ODE
// itself asserts when a NaN reaches a contact solve.)
TEST(Guard, NonFiniteStateStopsAtOnceAndDumpsLastGoodState) {
    std::string text = "[scene]\nname = \"nan\"\n";
    for (int i = 0; i < 8; ++i) {
        text += "[[bodies]]\nname = \"b" + std::to_string(i) + "\"\nposition = [" + std::to_string(3 * i) + ".0, 0.0, 10.0]\n";
    }
    const Scene sc = load_scene_text(text, "nan");
    const std::string dump = (std::filesystem::temp_directory_path() / "parode_guard_dump.csv").string();
    RunOptions opt;
    opt.collide = "ode-simple";
    opt.dump_path = dump;
    Pipeline p(sc, opt);
    for (int s = 0; s < 3; ++s) p.step();
    dBodySetLinearVel(p.world().body(7), std::nan(""), 0, 0);
    try {
        p.step();
        FAIL() << "the guard did not stop the run";
    } catch (const SimulationError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("step 4 "), std::string::npos) << m;
        EXPECT_NE(m.find("first ids: 7)"), std::string::npos) << m;
        EXPECT_NE(m.find("last good state (step 0)"), std::string::npos) << m;
    }
    std::ifstream in(dump);
    std::string line;
    int rows = 0;
    while (std::getline(in, line)) rows += line.empty() || line[0] == '#' ? 0 : 1;
    EXPECT_EQ(rows, 1 + 8);  // header + one row per body
    std::filesystem::remove(dump);
}

// Two of eight bodies over guard.max_speed: the message counts two and
// names those two, fastest first, and none of the bodies under the limit.
TEST(Guard, SpeedLimitNamesOnlyTheBodiesOverIt) {
    std::string text = "[scene]\nname = \"fast\"\n[guard]\nmax_speed = 50.0\n";
    for (int i = 0; i < 8; ++i) {
        text += "[[bodies]]\nname = \"b" + std::to_string(i) + "\"\nposition = [" + std::to_string(3 * i) + ".0, 0.0, 10.0]\n";
    }
    const Scene sc = load_scene_text(text, "fast");
    RunOptions opt;
    opt.collide = "ode-simple";
    Pipeline p(sc, opt);
    for (int i = 0; i < 8; ++i) dBodySetLinearVel(p.world().body(i), 10.0 + i, 0, 0);  // 10..17 m/s
    dBodySetLinearVel(p.world().body(2), 70, 0, 0);
    dBodySetLinearVel(p.world().body(5), 90, 0, 0);
    try {
        p.step();
        FAIL() << "the guard did not stop the run";
    } catch (const SimulationError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("2 bodies move faster than guard.max_speed = 50 m/s (fastest: 5 ("), std::string::npos) << m;
        EXPECT_NE(m.find(", 2 ("), std::string::npos) << m;
        EXPECT_EQ(m.find(", 7 ("), std::string::npos) << "a body under the limit named: " << m;
    }
}

// The overlap case gains ~120 J legitimately; a 10 J bound makes that a runaway.
TEST(Guard, RunawayEnergyStopsTheRunNamingStepAndBodies) {
    const Scene sc = test::repo_scene("jobs/scenes/hard/overlap.toml", {"guard.max_energy_gain=10.0"});
    try {
        test::run(sc, sc.steps);
        FAIL() << "the guard did not stop the run";
    } catch (const SimulationError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("runaway energy"), std::string::npos) << m;
        EXPECT_NE(m.find("fastest bodies"), std::string::npos) << m;
        EXPECT_EQ(m.rfind("step ", 0), 0u) << m;
    }
}

TEST(Guard, AutomaticBoundLetsTheClassicScenesRun) {
    for (const char* s : {"tennis", "magnetic-tennis", "buggy"}) {
        const Scene sc = test::repo_scene(std::string("jobs/scenes/") + s + ".toml", {"catoms.count=64"});
        EXPECT_NO_THROW(test::run(sc, 300)) << s;
    }
}

}  // namespace
