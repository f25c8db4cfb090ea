// Distributed runs through the real launcher, for the MPI tests: a fixture
// that runs `parode` without MPI or under mpiexec -n N (oversubscribed,
// passive waiting, allowed as root) with a time limit, and the check that a
// list of (ranks, threads) cases gives the state hash of the run without MPI.
// Trade-off: shell commands and files in a temporary folder, as a user runs
// them; each case is a whole process start-up.
#pragma once
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "binary.hpp"

namespace mpi_runs {

namespace fs = std::filesystem;

inline const std::string kSource = PARODE_SOURCE_DIR;

using parode::test::Result;
using parode::test::slurp;

inline std::size_t count(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

class Mpi : public parode::test::ScratchDirTest {
protected:
    Mpi() : ScratchDirTest("mpi") {}

    // `parode ARGS` on `ranks` processes (0: without mpiexec), stderr kept;
    // `var` (NAME=VALUE, or empty) set for it, and passed on to every process
    // by mpiexec (-x NAME).
    Result run(int ranks, const std::string& args, int timeout_s = 240, const std::string& var = "") const {
        std::string launcher =
            ranks > 0 ? std::string(PARODE_MPIEXEC) + " -n " + std::to_string(ranks) + " --oversubscribe " : "";
        if (ranks > 0 && !var.empty()) launcher += "-x " + var.substr(0, var.find('=')) + " ";
        std::string env = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive";
        if (!var.empty()) env += " " + var;
        return parode::test::run_parode({args, env, launcher, dir_, timeout_s});
    }
    nlohmann::json report(const std::string& name) const { return parode::test::read_json(dir_ / name); }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }
    // `parode ARGS` on each ranks x threads of `layouts` gives `ref`'s state
    // hash (its reports named TAG RxT.json).
    void expect_ref_hash(const std::string& args, const nlohmann::json& ref, const std::vector<std::pair<int, int>>& layouts,
                         const std::string& tag) const {
        for (const auto& [ranks, threads] : layouts) {
            const std::string name = tag + std::to_string(ranks) + "x" + std::to_string(threads) + ".json";
            const Result r = run(ranks, args + " --threads " + std::to_string(threads) + " --report " + path(name));
            ASSERT_EQ(r.rc, 0) << r.err;
            EXPECT_EQ(report(name)["state_hash"], ref["state_hash"]) << ranks << " ranks x " << threads << " threads";
        }
    }
};

struct Case {
    const char* scene;
    int ranks, threads;
};

class Ranks : public Mpi, public ::testing::WithParamInterface<const char*> {
protected:
    // The hash of 500 steps of 2,000 catoms without MPI, then on each of
    // `cases`, rebalancing whenever the load drifts by 2 %, invariants
    // checked every step.
    void same_hash(const std::vector<Case>& cases) {
        const std::string scene = kSource + "/jobs/scenes/" + GetParam() + ".toml";
        const std::string common = " run " + scene + " --steps 500 --collide grid --solver parallel -q --check-invariants 1"
                                   " --set catoms.count=2000 --set parallel.rebalance_threshold=1.02"
                                   " --set parallel.rebalance_every=5";
        ASSERT_EQ(run(0, common + " --threads 1 --report " + path("ref.json")).rc, 0);
        const nlohmann::json ref = report("ref.json");
        for (const Case& c : cases) {
            const std::string name = "r" + std::to_string(c.ranks) + "t" + std::to_string(c.threads) + ".json";
            const Result r = run(c.ranks, common + " --threads " + std::to_string(c.threads) + " --report " + path(name), 900);
            ASSERT_EQ(r.rc, 0) << c.ranks << " ranks x " << c.threads << " threads: " << r.err;
            const nlohmann::json j = report(name);
            EXPECT_EQ(j["state_hash"], ref["state_hash"]) << c.ranks << " ranks x " << c.threads << " threads";
            EXPECT_EQ(j["bodies"], 2000);
            EXPECT_EQ(j["ranks"], c.ranks);
            if (c.ranks > 1) {
                EXPECT_GT(j["parallel"]["migrations"].get<long>(), 0) << "bodies crossed between processes";
                EXPECT_GE(j["parallel"]["repartitions"].get<long>(), 1) << "the load drifted past 2 % at least once";
            }
        }
    }
};

}  // namespace mpi_runs
