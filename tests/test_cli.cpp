// The `parode` command line, end to end: runs the built executable (PARODE_BINARY)
// through the shell (or on a pseudo-terminal, for the progress bar) and checks
// exit codes, error messages, option ranges, output-path checks, the memory
// refusal, the JSON run report and that the state hash is reproducible and
// depends on the seed; and, in-process, the guard's exception -> exit code map.
// Trade-off: real processes on real scene files test what a user sees (option
// parsing, the error guard, file output) at the cost of a process start per
// check, so every run is tiny (8 catoms, 20 steps) and the whole file takes a
// few seconds.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <ode/ode.h>
#include <pty.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "cli_common.hpp"
#include "binary.hpp"
#include "util/errors.hpp"
#include "run/memory_estimate.hpp"
#include "run/pipeline.hpp"
#include "scene/toml_reader.hpp"

namespace {

namespace fs = std::filesystem;
using parode::test::slurp;

const std::string kSourceDir = PARODE_SOURCE_DIR;
const std::string kTennis = kSourceDir + "/jobs/scenes/tennis.toml";
const std::string kMagnetic = kSourceDir + "/jobs/scenes/magnetic-tennis.toml";
const std::string kSmall = " --set catoms.count=8 --steps 20 --threads 1 -q";

using parode::test::Result;

class Cli : public parode::test::ScratchDirTest {
protected:
    Cli() : ScratchDirTest("cli") {}

    // `parode ARGS` with stdout and stderr captured separately; `env`
    // ("NAME=value ") is set for that command alone.
    Result parode(const std::string& args, const std::string& env = "") const {
        return parode::test::run_parode({args, env, "", dir_, 0});
    }

    // Runs a small simulation of `scene` and returns its parsed report.
    nlohmann::json report(const std::string& scene, const std::string& extra = "") const {
        const fs::path path = dir_ / "report.json";
        fs::remove(path);
        const Result r = parode("run '" + scene + "'" + kSmall + extra + " --report '" + path.string() + "'");
        EXPECT_EQ(r.rc, 0) << r.err;
        EXPECT_TRUE(fs::exists(path)) << r.err;
        return parode::test::read_json(path);
    }
};

TEST_F(Cli, HelpListsRun) {
    const Result r = parode("--help");
    EXPECT_EQ(r.rc, 0);
    EXPECT_NE(r.out.find("run"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("Simulate a scene"), std::string::npos) << r.out;
}

TEST_F(Cli, NoSubcommandIsUsageError) {
    const Result r = parode("");
    EXPECT_EQ(r.rc, 2) << r.err;
}

TEST_F(Cli, BadSceneExits3AndNamesTheFile) {
    const Result r = parode("run '" + kSourceDir + "/tests/data/bad/bad_dt.toml'" + kSmall);
    EXPECT_EQ(r.rc, 3) << r.err;
    EXPECT_NE(r.err.find("scene error"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("bad_dt.toml:7:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("'scene.dt'"), std::string::npos) << r.err;
}

TEST_F(Cli, MissingSceneExits3) {
    const Result r = parode("run /nonexistent/scene.toml -q");
    EXPECT_EQ(r.rc, 3) << r.err;
    EXPECT_NE(r.err.find("/nonexistent/scene.toml: cannot open scene file"), std::string::npos) << r.err;
}

TEST_F(Cli, BadSetExits3) {
    const Result r = parode("run '" + kTennis + "' --set catoms.count=0 --steps 1 -q");
    EXPECT_EQ(r.rc, 3) << r.err;
    EXPECT_NE(r.err.find("--set catoms.count=0"), std::string::npos) << r.err;
    const Result idx = parode("run '" + kTennis + "' --set materials.x.mu=1 --steps 1 -q");
    EXPECT_EQ(idx.rc, 3) << idx.err;
    EXPECT_NE(idx.err.find("'x' is not an array index"), std::string::npos) << idx.err;
}

TEST_F(Cli, UnknownCollideExits2) {
    const Result r = parode("run '" + kTennis + "'" + kSmall + " --collide no-such-backend");
    EXPECT_EQ(r.rc, 2) << r.err;
    EXPECT_NE(r.err.find("no-such-backend"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("ode-hash"), std::string::npos) << "the message lists the backends: " << r.err;
}

TEST_F(Cli, ReportHasEveryKey) {
    const nlohmann::json j = report(kTennis);
    EXPECT_EQ(j.at("scene"), "tennis");
    EXPECT_EQ(j.at("bodies"), 8);
    EXPECT_EQ(j.at("steps"), 20);
    EXPECT_DOUBLE_EQ(j.at("dt").get<double>(), 0.005);
    EXPECT_EQ(j.at("threads"), 1);
    EXPECT_EQ(j.at("ranks"), 1);
    EXPECT_GT(j.at("wall_s").get<double>(), 0.0);
    // The first step's collision runs before the loop that wall_s times; a
    // step's cost includes it.
    EXPECT_GT(j.at("steps_wall_s").get<double>(), j.at("wall_s").get<double>());
    EXPECT_NEAR(j.at("ms_per_step").get<double>(), 1000.0 * j.at("steps_wall_s").get<double>() / 20, 1e-9);
    for (const char* s : {"forces", "collide", "joints", "solve", "observe", "output"}) {
        ASSERT_TRUE(j.at("stages").contains(s)) << s;
        EXPECT_GE(j["stages"][s].get<double>(), 0.0) << s;
        EXPECT_TRUE(j.at("stages_run").contains(s)) << s;
    }
    // The first step alone: part of the run's stages, its collision (run while
    // the pipeline was built) included, and less solving than 20 steps.
    const auto& first = j.at("first_step");
    EXPECT_GT(first.at("wall_s").get<double>(), 0.0);
    EXPECT_LT(first["wall_s"].get<double>(), j["steps_wall_s"].get<double>());
    EXPECT_GE(first.at("stages").at("collide").get<double>(),
              j["steps_wall_s"].get<double>() - j["wall_s"].get<double>() - 1e-9);
    EXPECT_LT(first["stages"].at("solve").get<double>(), j["stages"]["solve"].get<double>());
    for (const auto& [s, v] : first["stages"].items()) EXPECT_LE(v.get<double>(), j["stages"].at(s).get<double>()) << s;
    EXPECT_GT(j.at("contacts_per_step").get<double>(), 0.0) << "the bottom balls touch the floor";
    EXPECT_TRUE(std::regex_match(j.at("state_hash").get<std::string>(), std::regex("[0-9a-f]{16}")))
        << j["state_hash"];
    const auto& d = j.at("diagnostics");
    EXPECT_GE(d.at("max_penetration").get<double>(), d.at("mean_penetration").get<double>());
    EXPECT_EQ(d.at("nan_count"), 0);
    EXPECT_TRUE(d.at("energy").contains("total"));
    const auto& b = j.at("build");
    EXPECT_FALSE(b.at("compiler").get<std::string>().empty());
    EXPECT_TRUE(b.at("flags").is_string());
    EXPECT_EQ(b.at("ode_version").get<std::string>().rfind("0.16", 0), 0u) << b["ode_version"];
    EXPECT_EQ(b.at("precision"), "double");
}

// `parode memory` measures the triad on 1..T threads and five fresh mappings
// each in 4 KB and 2 MB pages; rates are finite and positive.
TEST_F(Cli, MemoryProbeMeasuresEveryThreadCount) {
    const fs::path path = dir_ / "memory.json";
    const Result r = parode("memory --mb 4 --threads 2 --json '" + path.string() + "'");
    ASSERT_EQ(r.rc, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(slurp(path));
    EXPECT_EQ(j.at("threads"), nlohmann::json({1, 2}));
    ASSERT_EQ(j.at("triad_gb_s").size(), 2u);
    for (const char* k : {"triad_gb_s", "first_touch_gb_s", "first_touch_huge_gb_s"}) {
        for (const auto& v : j.at(k)) {
            EXPECT_GT(v.get<double>(), 0.0) << k;
            EXPECT_LT(v.get<double>(), 1e5) << k;
        }
    }
    EXPECT_EQ(j.at("first_touch_gb_s").size(), 5u);
    EXPECT_NE(r.out.find("triad, 2 thread(s):"), std::string::npos) << r.out;
    EXPECT_EQ(parode("memory --threads 0").rc, 2);
}

// PARODE_HUGE_PAGES: 0 turns the huge-page advice off (the probe says so),
// 1 keeps it; anything else stops before any work, naming the variable.
TEST_F(Cli, HugePagesSwitch) {
    const Result off = parode("memory --mb 4 --threads 1", "PARODE_HUGE_PAGES=0 ");
    ASSERT_EQ(off.rc, 0) << off.err;
    EXPECT_NE(off.out.find("4 KB (PARODE_HUGE_PAGES=0) pages"), std::string::npos) << off.out;
    const Result on = parode("memory --mb 4 --threads 1", "PARODE_HUGE_PAGES=1 ");
    ASSERT_EQ(on.rc, 0) << on.err;
    EXPECT_NE(on.out.find("2 MB pages"), std::string::npos) << on.out;
    const Result bad = parode("run '" + kTennis + "'" + kSmall, "PARODE_HUGE_PAGES=yes ");
    EXPECT_EQ(bad.rc, 2) << bad.err;
    EXPECT_NE(bad.err.find("PARODE_HUGE_PAGES=yes: expected 0"), std::string::npos) << bad.err;
}

// The report's peak memory in parts (memory.peak_by_stage): the set-up's
// peak and what each stage added to it over the steps sum to the peak; the
// solve's part is its rows and scratch, which grow with the catoms (twice
// the catoms, at least 1.5 times its part; huge pages off, whose
// availability moves a peak by 2 MB).
TEST_F(Cli, PeakMemoryInPartsByStage) {
    std::int64_t solve[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
        const fs::path path = dir_ / "peak.json";
        const Result r = parode("run '" + kTennis + "' --set catoms.count=" + std::to_string(20000 << k) +
                                    " --steps 2 --threads 1 -q --collide grid --solver parallel --report '" +
                                    path.string() + "'",
                                "PARODE_HUGE_PAGES=0 ");
        ASSERT_EQ(r.rc, 0) << r.err;
        const nlohmann::json m = parode::test::read_json(path).at("memory");
        const auto& parts = m.at("peak_by_stage");
        std::int64_t sum = 0;
        for (const auto& [name, v] : parts.items()) {
            EXPECT_GE(v.get<std::int64_t>(), 0) << name;
            sum += v.get<std::int64_t>();
        }
        EXPECT_EQ(sum, m.at("peak_rss_bytes").at("max").get<std::int64_t>()) << parts;
        for (const char* s : {"setup", "solve", "collide", "other"}) EXPECT_TRUE(parts.contains(s)) << s;
        solve[k] = parts.at("solve").get<std::int64_t>();
    }
    EXPECT_GT(solve[0], 1 << 20) << "the first step's rows";
    EXPECT_GE(static_cast<double>(solve[1]), 1.5 * static_cast<double>(solve[0]));
}

TEST_F(Cli, StagesRunFollowTheScene) {
    const nlohmann::json plain = report(kTennis);
    EXPECT_EQ(plain.at("stages_run").at("forces").at("ran"), false);
    EXPECT_EQ(plain["stages_run"]["collide"]["ran"], true);
    const nlohmann::json magnetic = report(kMagnetic);
    EXPECT_EQ(magnetic.at("scene"), "magnetic-tennis");
    EXPECT_EQ(magnetic.at("stages_run").at("forces").at("ran"), true);
}

// The grid's neighbour list is built and then serves calls; without it (or
// with ODE's space) there is nothing to count, and the hash is the same.
TEST_F(Cli, ReportCountsTheNeighbourListsWork) {
    const nlohmann::json j = report(kTennis, " --collide grid");
    const auto& c = j.at("collide_counts");
    const auto builds = c.at("neighbour_list_builds").get<std::int64_t>();
    const auto uses = c.at("neighbour_list_uses").get<std::int64_t>();
    EXPECT_GE(builds, 1);
    EXPECT_GE(uses, 1);
    EXPECT_LE(builds + uses, j.at("steps").get<std::int64_t>()) << "one collision a step";
    EXPECT_EQ(c.at("neighbour_list_declined").get<std::int64_t>(), 0);
    const nlohmann::json off = report(kTennis, " --collide grid-nolist");
    EXPECT_EQ(off.at("collide_counts").at("neighbour_list_builds").get<std::int64_t>(), 0);
    EXPECT_EQ(off.at("collide_counts").at("neighbour_list_uses").get<std::int64_t>(), 0);
    EXPECT_EQ(off.at("state_hash"), j.at("state_hash"));
    EXPECT_TRUE(report(kTennis, " --collide ode-hash").at("collide_counts").empty());
}

TEST_F(Cli, ReportAndSummaryHaveTheSubstagesOfGridAndProjectSolver) {
    const nlohmann::json j = report(kTennis, " --collide grid --solver parallel");
    const std::map<std::string, std::vector<std::string>> expect = {
        {"solve", {"build", "warm_start", "sweeps", "integrate"}},
        {"collide", {"refresh", "broadphase", "narrowphase", "merge"}}};
    for (const auto& [stage, subs] : expect) {
        double sum = 0;
        for (const std::string& sub : subs) {
            ASSERT_TRUE(j.at("substages").at(stage).contains(sub)) << stage << "." << sub;
            const double v = j["substages"][stage][sub].get<double>();
            EXPECT_GE(v, 0.0) << stage << "." << sub;
            sum += v;
        }
        EXPECT_GT(sum, 0.0) << stage;
        EXPECT_LE(sum, 1.01 * j["stages"][stage].get<double>() + 1e-4) << stage << ": substages lie within their stage";
    }
    EXPECT_TRUE(report(kTennis, " --collide ode-hash --solver ode").at("substages").empty()) << "ODE's space and stepper have no substages";
    const Result r = parode("run '" + kTennis + "' --set catoms.count=8 --steps 20 --threads 1 --collide grid --solver pgs");
    EXPECT_NE(r.out.find("\n    sweeps "), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\n    narrowphase "), std::string::npos) << r.out;
}

TEST_F(Cli, SummaryShowsTheReportedHash) {
    const nlohmann::json j = report(kTennis);
    const Result r = parode("run '" + kTennis + "' --set catoms.count=8 --steps 20 --threads 1");
    EXPECT_EQ(r.rc, 0) << r.err;
    EXPECT_NE(r.out.find("parode run: tennis (8 bodies, 20 steps"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("state hash " + j["state_hash"].get<std::string>()), std::string::npos) << r.out;
    const Result quiet = parode("run '" + kTennis + "'" + kSmall);
    EXPECT_EQ(quiet.rc, 0);
    EXPECT_EQ(quiet.out, "") << "-q prints nothing";
}

TEST_F(Cli, UnwritableReportExits4) {
    const Result r = parode("run '" + kTennis + "'" + kSmall + " --report /nonexistent/dir/r.json");
    EXPECT_EQ(r.rc, 4) << r.err;
    EXPECT_NE(r.err.find("/nonexistent/dir/r.json"), std::string::npos) << r.err;
}

TEST_F(Cli, VersionNamesProjectOdeOpenMpAndMpi) {
    const Result r = parode("--version");
    EXPECT_EQ(r.rc, 0) << r.err;
    EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(^parode \d+\.\d+\.\d+ \(git commit )"))) << r.out;
    EXPECT_NE(r.out.find("ODE 0.16"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("double precision"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("OpenMP: "), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("MPI: "), std::string::npos) << r.out;
}

// Every numeric option says what it expects, in a readable range.
TEST_F(Cli, OutOfRangeOptionsExit2WithReadableRanges) {
    const struct {
        const char* args;
        const char* message;
    } cases[] = {
        {"--threads 100000", "--threads: expected an integer in [1, 1024], got '100000'"},
        {"--threads 0", "--threads: expected an integer in [1, 1024], got '0'"},
        {"--steps -5", "--steps: expected an integer in [0, 1000000000], got '-5'"},
        {"--steps abc", "--steps: expected an integer in [0, 1000000000], got 'abc'"},
        {"--duration nan", "--duration: expected a number in [0, 1e+09], got 'nan'"},
        {"--snapshot-every 0 --snapshot x.csv", "--snapshot-every: expected an integer in [1, 1000000000], got '0'"},
        {"--snapshot-every 5", "--snapshot-every requires --snapshot"},
        {"--solver fast", "--solver: fast not in {"},
    };
    for (const auto& c : cases) {
        const Result r = parode("run '" + kTennis + "' --set catoms.count=8 -q " + c.args);
        EXPECT_EQ(r.rc, 2) << c.args << ": " << r.err;
        EXPECT_NE(r.err.find(c.message), std::string::npos) << c.args << ": " << r.err;
        EXPECT_LT(r.err.size(), 300u) << "no 300-digit ranges: " << r.err;
    }
}

TEST_F(Cli, OmpNumThreadsIsBoundedToo) {
    const fs::path err = dir_ / "e.txt";
    const std::string cmd = "OMP_NUM_THREADS=100000 '" + std::string(PARODE_BINARY) + "' run '" + kTennis +
                            "' --set catoms.count=8 --steps 1 -q 2>'" + err.string() + "'";
    const int status = std::system(cmd.c_str());
    EXPECT_EQ(WEXITSTATUS(status), 2);
    EXPECT_NE(slurp(err).find("OMP_NUM_THREADS=100000: expected an integer in [1, 1024]"), std::string::npos)
        << slurp(err);
}

// A bad output path is found before the run: the run's snapshot file (opened
// when the run starts) is never created.
TEST_F(Cli, UnwritableOutputsExit4BeforeTheRun) {
    const fs::path started = dir_ / "started.csv";
    const std::string run = "run '" + kTennis + "' --set catoms.count=8 --steps 20 -q --snapshot '" + started.string() + "' ";
    const std::string missing = "/nonexistent/dir/out";
    const struct {
        std::string args;
        std::string message;
    } cases[] = {
        {run + "--report " + missing, "--report " + missing + ": cannot write there: the directory /nonexistent/dir does not exist"},
        {run + "--trajectory " + missing, "--trajectory " + missing},
        {"run '" + kTennis + "' --set catoms.count=8 --steps 20 -q --snapshot " + missing, "--snapshot " + missing},
        {run + "--dump-on-failure " + missing, "--dump-on-failure " + missing},
        {run + "--report '" + dir_.string() + "'", "--report " + dir_.string() + ": cannot write there: it is a directory"},
        {run + "--report '" + (dir_ / "stdout.txt" / "r.json").string() + "'",
         "--report " + (dir_ / "stdout.txt" / "r.json").string() + ": cannot write there: " +
             (dir_ / "stdout.txt").string() + " is not a directory"},
        {"bench collide '" + kTennis + "' --set catoms.count=8 --steps 20 --csv " + missing, "--csv " + missing},
        {"compare a.traj b.traj --report " + missing, "--report " + missing},
    };
    for (const auto& c : cases) {
        const Result r = parode(c.args);
        EXPECT_EQ(r.rc, 4) << c.args << ": " << r.err;
        EXPECT_NE(r.err.find("parode: cannot write output: " + c.message), std::string::npos) << c.args << ": " << r.err;
        EXPECT_FALSE(fs::exists(started)) << "the run started before the check: " << c.args;
    }
}

TEST_F(Cli, OutputCheckCreatesNothing) {
    const fs::path report = dir_ / "new.json";
    const Result r = parode("run '" + kSourceDir + "/tests/data/bad/bad_dt.toml' -q --report '" + report.string() + "'");
    EXPECT_EQ(r.rc, 3) << r.err;
    EXPECT_FALSE(fs::exists(report)) << "the probe file was left behind";
}

TEST_F(Cli, GuardStopExits1) {
    const Result r = parode("run '" + kTennis + "'" + kSmall + " --set guard.max_speed=0.01");
    EXPECT_EQ(r.rc, 1) << r.err;
    EXPECT_NE(r.err.find("parode: simulation failed: step "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("faster than guard.max_speed = 0.01 m/s"), std::string::npos) << r.err;
}

TEST_F(Cli, FailedChecksExit5) {
    const Result r = parode("run '" + kTennis + "'" + kSmall + " --set checks.max_energy_gain=-1e9");
    EXPECT_EQ(r.rc, 5) << r.err;
    EXPECT_NE(r.err.find("parode: checks failed: max_energy_gain"), std::string::npos) << r.err;
}

// 1e8 catoms: refused from the estimate before the prism exists (20 GB of
// bodies), even under a 400 MB address-space limit that any allocation of
// that size would hit first.
TEST_F(Cli, HugeCatomCountExits6AtOnce) {
#ifdef PARODE_SANITIZED
    GTEST_SKIP() << "AddressSanitizer reserves terabytes of address space: a ulimit -v cannot be tested under it";
#endif
    const fs::path err = dir_ / "e.txt";
    const std::string cmd = "ulimit -v 400000; '" + std::string(PARODE_BINARY) + "' run '" + kTennis +
                            "' --set catoms.count=100000000 --collide grid -q 2>'" + err.string() + "'";
    const auto t0 = std::chrono::steady_clock::now();
    const int status = std::system(("sh -c \"" + cmd + "\"").c_str());
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::string msg = slurp(err);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 6) << status << ": " << msg;
    EXPECT_NE(msg.find("parode: not enough memory: the run needs about "), std::string::npos) << msg;
    EXPECT_NE(msg.find("100000000 bodies"), std::string::npos) << msg;
    EXPECT_NE(msg.find("is available ("), std::string::npos) << msg;
    EXPECT_LT(s, 1.0) << "refused before building anything";
}

// A count the machine could hold, refused because of the address-space limit:
// the estimate reads the limits the process runs under.
TEST_F(Cli, EstimateHonoursTheAddressSpaceLimit) {
#ifdef PARODE_SANITIZED
    GTEST_SKIP() << "AddressSanitizer reserves terabytes of address space: a ulimit -v cannot be tested under it";
#endif
    const fs::path err = dir_ / "e.txt";
    const std::string cmd = "ulimit -v 600000; '" + std::string(PARODE_BINARY) + "' run '" + kTennis +
                            "' --set catoms.count=400000 --collide grid --solver parallel -q --steps 2 2>'" +
                            err.string() + "'";
    const int status = std::system(("sh -c \"" + cmd + "\"").c_str());
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 6) << status << ": " << slurp(err);
    EXPECT_NE(slurp(err).find("the address-space limit (ulimit -v)"), std::string::npos) << slurp(err);
}

TEST_F(Cli, CompareTakesCommaSeparatedHorizons) {
    const fs::path run = dir_ / "run.traj", ref = dir_ / "ref.traj", out = dir_ / "cmp.json";
    const std::string base = "run '" + kTennis + "' --set catoms.count=8 --steps 40 --threads 1 -q --set scene.observe_every=5 ";
    ASSERT_EQ(parode(base + "--trajectory '" + run.string() + "'").rc, 0);
    ASSERT_EQ(parode(base + "--set solver.iterations=40 --trajectory '" + ref.string() + "'").rc, 0);
    const Result r = parode("compare '" + run.string() + "' '" + ref.string() + "' -q --horizons 10,20,40 --report '" +
                            out.string() + "'");
    ASSERT_EQ(r.rc, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(slurp(out));
    std::vector<long> steps;
    for (const auto& h : j.at("error").at("trajectory")) steps.push_back(h.at("step").get<long>());
    EXPECT_EQ(steps, (std::vector<long>{10, 20, 40})) << j["error"]["trajectory"].dump();
    const Result bad = parode("compare '" + run.string() + "' '" + ref.string() + "' -q --horizons 10,-5");
    EXPECT_EQ(bad.rc, 2) << bad.err;
    EXPECT_NE(bad.err.find("--horizons: expected an integer in [1, 1000000000], got '-5'"), std::string::npos) << bad.err;
}

// The RMS error is taken at exactly --error-at, also when --every does not divide it.
TEST_F(Cli, BenchStepMeasuresErrorAtTheStepAsked) {
    const fs::path csv = dir_ / "step.csv";
    const Result r = parode("bench step '" + kTennis + "' --set catoms.count=8 --backends ode-hash/ode:1 --steps 20 "
                            "--every 7 --error-at 10 --reference-iterations 40 --csv '" + csv.string() + "'");
    ASSERT_EQ(r.rc, 0) << r.err;
    std::istringstream in(slurp(csv));
    std::string header, row;
    std::getline(in, header);
    std::getline(in, row);
    ASSERT_EQ(header, "scene,bodies,steps,variant,ms_per_step,collide_ms,solve_ms,speedup_vs_first,rms_at,error_at");
    std::vector<std::string> f;
    std::istringstream cells(row);
    for (std::string c; std::getline(cells, c, ',');) f.push_back(c);
    ASSERT_EQ(f.size(), 10u) << row;
    EXPECT_GE(std::stod(f[8]), 0.0) << "rms_at was not measured: " << row;
    EXPECT_EQ(f[9], "10");
    const Result past = parode("bench step '" + kTennis + "' --set catoms.count=8 --backends ode-hash/ode:1 --steps 20 "
                               "--error-at 30 --reference-iterations 40");
    EXPECT_EQ(past.rc, 2) << past.err;
    EXPECT_NE(past.err.find("--error-at 30 is past the last step (20)"), std::string::npos) << past.err;
}

TEST_F(Cli, BenchVariantThreadsAreChecked) {
    const Result r = parode("bench collide '" + kTennis + "' --set catoms.count=8 --backends grid:abc --steps 1");
    EXPECT_EQ(r.rc, 2) << r.err;
    EXPECT_NE(r.err.find("--backends grid:abc: expected NAME:THREADS with THREADS an integer in [1, 1024]"),
              std::string::npos) << r.err;
}

// Runs `parode ARGS` with its terminal on a pseudo-terminal (so the progress
// bar is drawn); returns all it wrote (stdout and stderr) and its exit code.
Result on_terminal(const std::vector<std::string>& args) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    int master = -1;
    const pid_t pid = forkpty(&master, nullptr, nullptr, nullptr);
    if (pid == 0) {
        execv(argv[0], argv.data());
        _exit(127);
    }
    Result r;
    char buf[4096];
    for (ssize_t n; (n = read(master, buf, sizeof buf)) > 0;) r.out.append(buf, static_cast<std::size_t>(n));
    int status = 0;
    waitpid(pid, &status, 0);
    close(master);
    r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
}

TEST_F(Cli, ProgressBarShowsRateAndTimeLeft) {
    const Result r = on_terminal({PARODE_BINARY, "run", kTennis, "--set", "catoms.count=8", "--steps", "300", "--threads", "1"});
    ASSERT_EQ(r.rc, 0) << r.out;
    EXPECT_NE(r.out.find("step 300/300"), std::string::npos) << r.out;
    EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(\d+\.\d s  \d+\.\d steps/s  (\d+\.\d s|\d+ min \d+ s|\?) left)")))
        << r.out;
    const auto summary = r.out.find("parode run: tennis");
    ASSERT_NE(summary, std::string::npos) << r.out;
    EXPECT_EQ(r.out[summary - 1], '\n') << "the summary shares the bar's line: " << r.out;
}

// The guard stops the run at about step 4 while the bar's line is open: the
// message must start a line of its own.
TEST_F(Cli, ErrorMessageEndsTheProgressLineFirst) {
    const Result r = on_terminal({PARODE_BINARY, "run", kTennis, "--set", "catoms.count=8", "--steps", "300",
                                  "--threads", "1", "--set", "guard.max_speed=0.2"});
    EXPECT_EQ(r.rc, 1) << r.out;
    EXPECT_NE(r.out.find("step 1/300"), std::string::npos) << "the bar was drawn: " << r.out;
    const auto msg = r.out.find("parode: simulation failed");
    ASSERT_NE(msg, std::string::npos) << r.out;
    EXPECT_EQ(r.out[msg - 1], '\n') << "the message is glued to the bar: " << r.out;
}

// The guard maps each exception type to its exit code and a message; the ones
// a user cannot provoke end to end (bad_alloc, a bug) are thrown here.
TEST(Guarded, EachExceptionTypeHasItsExitCode) {
    const struct {
        std::function<int()> action;
        int code;
        const char* message;
    } cases[] = {
        {[]() -> int { throw parode::SimulationError("step 3"); }, 1, "parode: simulation failed: step 3"},
        {[]() -> int { throw std::invalid_argument("--x: bad"); }, 2, "parode: --x: bad"},
        {[]() -> int { throw parode::SceneError("a.toml:1: bad"); }, 3, "parode: scene error: a.toml:1: bad"},
        {[]() -> int { throw parode::OutputError("r.json: no"); }, 4, "parode: cannot write output: r.json: no"},
        {[]() -> int { throw parode::MemoryError("needs 2 GB"); }, 6, "parode: not enough memory: needs 2 GB"},
        {[]() -> int { throw std::bad_alloc(); }, 6, "parode: out of memory: an allocation failed (std::bad_alloc)"},
        {[]() -> int { throw std::out_of_range("stoi"); }, 70,
         "parode: internal error (a bug in parode; please report it with the command line): stoi"},
        {[]() -> int { throw 42; }, 70, "parode: internal error (a bug in parode): an exception of unknown type"},
        {[]() -> int { return 5; }, 5, ""},
    };
    for (const auto& c : cases) {
        std::ostringstream err;
        std::streambuf* old = std::cerr.rdbuf(err.rdbuf());
        const int rc = parode::cli::guarded(c.action);
        std::cerr.rdbuf(old);
        EXPECT_EQ(rc, c.code) << c.message;
        EXPECT_EQ(err.str().rfind(c.message, 0), 0u) << err.str();
    }
    EXPECT_EQ(parode::cli::kExitInterrupted, 7) << "reserved, documented in README and main.cpp";
}

// An ODE internal check that a scene still reaches ends the process with the
// simulation-failed code and ODE's message, not SIGABRT (in a child process:
// the handler exits).
TEST(OdeHandlers, InternalCheckExits1WithOdesMessage) {
    const fs::path err = fs::temp_directory_path() / ("parode_ode_handler_" + std::to_string(::getpid()));
    const pid_t pid = fork();
    if (pid == 0) {
        if (!std::freopen(err.c_str(), "w", stderr)) _exit(99);
        parode::cli::install_ode_handlers();
        dDebug(1, "assertion \"%s\" failed", "aabbBound < dMaxIntExact");
        _exit(98);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    const std::string msg = slurp(err);
    fs::remove(err);
    ASSERT_TRUE(WIFEXITED(status)) << "signal " << WTERMSIG(status);
    EXPECT_EQ(WEXITSTATUS(status), 1) << msg;
    EXPECT_EQ(msg.rfind("parode: simulation failed: ODE stopped on an internal check (1: assertion \"aabbBound < "
                        "dMaxIntExact\" failed)", 0), 0u) << msg;
}

TEST_F(Cli, StateHashIsReproducibleAndSeeded) {
    const std::string first = report(kTennis).at("state_hash");
    const std::string again = report(kTennis).at("state_hash");
    const std::string reseeded = report(kTennis, " --set scene.seed=2").at("state_hash");
    EXPECT_EQ(first, again);
    EXPECT_NE(first, reseeded);
}

}  // namespace
