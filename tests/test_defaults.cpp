// The defaults of a run: grid collision and parode's solver unless the scene's
// [run] table or the command line says otherwise (the command line wins); a
// [run] name that no backend has is a scene error naming file, line and key;
// threads come from --threads, [run], OMP_NUM_THREADS, SLURM_CPUS_PER_TASK or
// the affinity mask, and the report says which; ODE's hash space at a size it
// cannot hold is refused before anything is built, pointing at the grid.
// Trade-off: the real binary on tiny scenes (a few catoms, a few steps).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "binary.hpp"

namespace {

namespace fs = std::filesystem;
const std::string kScenes = std::string(PARODE_SOURCE_DIR) + "/jobs/scenes/";

class Defaults : public parode::test::ScratchDirTest {
protected:
    Defaults() : ScratchDirTest("defaults") {}
    // `env parode run ARGS --report r.json`: the exit code; report() reads r.json.
    int run(const std::string& args, const std::string& env = "-u OMP_NUM_THREADS -u SLURM_CPUS_PER_TASK") const {
        return parode::test::run_parode({"run " + args + " --steps 3 -q --report r.json", env, "", dir_, 0}).rc;
    }
    nlohmann::json report() const { return parode::test::read_json(dir_ / "r.json"); }
    std::string err() const { return parode::test::slurp(dir_ / "stderr.txt"); }
    std::string scene(const std::string& run_table) const {
        const fs::path p = dir_ / "s.toml";
        std::ofstream(p) << "[scene]\nname = \"s\"\n[catoms]\ncount = 8\n[[planes]]\nnormal = [0.0, 0.0, 1.0]\n" << run_table;
        return p.string();
    }
};

TEST_F(Defaults, GridAndParallelWithoutRunTable) {
    ASSERT_EQ(run(scene("")), 0) << err();
    EXPECT_EQ(report()["backends"]["collide"], "grid");
    EXPECT_EQ(report()["backends"]["solve"], "parallel");
}

TEST_F(Defaults, RunTableChoosesAndCommandLineOverrides) {
    const std::string s = scene("[run]\ncollide = \"ode-sap\"\nsolver = \"pgs\"\nthreads = 1\n");
    ASSERT_EQ(run(s), 0) << err();
    EXPECT_EQ(report()["backends"]["collide"], "ode-sap");
    EXPECT_EQ(report()["backends"]["solve"], "pgs");
    EXPECT_EQ(report()["threads_from"], "the scene's [run] threads");
    ASSERT_EQ(run(s + " --collide grid --solver ode --threads 2"), 0) << err();
    EXPECT_EQ(report()["backends"]["collide"], "grid");
    EXPECT_EQ(report()["backends"]["solve"], "ode-quickstep");
    EXPECT_EQ(report()["threads"], 2);
    EXPECT_EQ(report()["threads_from"], "--threads");
}

TEST_F(Defaults, UnknownRunBackendIsASceneError) {
    EXPECT_EQ(run(scene("[run]\ncollide = \"octree\"\n")), 3);
    EXPECT_NE(err().find("s.toml:8: key 'run.collide': expected one of \"ode-hash\""), std::string::npos) << err();
    EXPECT_NE(err().find("got \"octree\""), std::string::npos) << err();
}

TEST_F(Defaults, ThreadsFromEnvironmentThenAffinity) {
    ASSERT_EQ(run(scene(""), "env OMP_NUM_THREADS=3"), 0) << err();
    EXPECT_EQ(report()["threads"], 3);
    EXPECT_EQ(report()["threads_from"], "OMP_NUM_THREADS");
    ASSERT_EQ(run(scene(""), "env -u OMP_NUM_THREADS SLURM_CPUS_PER_TASK=2"), 0) << err();
    EXPECT_EQ(report()["threads_from"], "SLURM_CPUS_PER_TASK");
    ASSERT_EQ(run(scene(""), "env -u OMP_NUM_THREADS -u SLURM_CPUS_PER_TASK taskset -c 0"), 0) << err();
    EXPECT_EQ(report()["threads"], 1) << "one core in the affinity mask";
    EXPECT_EQ(report()["threads_from"], "the 1 cores of the affinity mask");
}

TEST_F(Defaults, ClassicScenesNameTheirBackends) {
    ASSERT_EQ(run(kScenes + "buggy.toml"), 0) << err();
    EXPECT_EQ(report()["backends"]["collide"], "grid");
    EXPECT_EQ(report()["backends"]["solve"], "ode-worldstep");
    ASSERT_EQ(run(kScenes + "magnetic-tennis.toml --set catoms.count=27"), 0) << err();
    EXPECT_EQ(report()["backends"]["solve"], "parallel");
}

TEST_F(Defaults, HashSpaceThatCannotFitIsRefusedBeforeBuilding) {
    EXPECT_EQ(run(kScenes + "tennis.toml --set catoms.count=1000000 --collide ode-hash"), 6);
    EXPECT_NE(err().find("--collide grid gives the same contacts"), std::string::npos) << err();
}

}  // namespace
