// Checkpoint and restart, end to end through the parode command: a run of
// 2k steps equals a run of k steps restarted for k more, bit for bit (state
// hash, and the run's totals), on parode's solver, ODE's QuickStep (with its
// dRand state), dWorldStep with joints and a driver, and magnets; a
// checkpoint of another scene, or a damaged one, is refused with the reason;
// SIGTERM finishes the step, writes a checkpoint and a report marked
// interrupted, exits 7, and the checkpoint continues the run exactly.
// Trade-off: real processes and files, small scenes (500 catoms, 200 steps).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "scratch_dir.hpp"

namespace {

namespace fs = std::filesystem;

const std::string kScenes = std::string(PARODE_SOURCE_DIR) + "/jobs/scenes/";

class Restart : public parode::test::ScratchDirTest {
protected:
    Restart() : ScratchDirTest("restart") {}
    int parode(const std::string& args) const {
        const std::string cmd = "cd '" + dir_.string() + "' && '" + PARODE_BINARY + "' " + args + " 2>stderr.txt >/dev/null";
        const int status = std::system(cmd.c_str());
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }
    nlohmann::json report(const std::string& name) const {
        std::ifstream in(dir_ / name);
        return nlohmann::json::parse(in);
    }
    std::string err() const { return parode::test::slurp(dir_ / "stderr.txt"); }
};

struct Config {
    const char* name;
    const char* args;
};

void PrintTo(const Config& c, std::ostream* os) { *os << c.name; }

class RestartEquals : public Restart, public ::testing::WithParamInterface<Config> {};

TEST_P(RestartEquals, UninterruptedRun) {
    const std::string a = kScenes + GetParam().args + " -q";
    ASSERT_EQ(parode("run " + a + " --steps 200 --report full.json"), 0) << err();
    ASSERT_EQ(parode("run " + a + " --steps 100 --checkpoint half.ckpt"), 0) << err();
    ASSERT_EQ(parode("run " + a + " --restart half.ckpt --steps 100 --report rest.json"), 0) << err();
    const nlohmann::json full = report("full.json"), rest = report("rest.json");
    EXPECT_EQ(rest["state_hash"], full["state_hash"]);
    EXPECT_TRUE(rest["restart"]["exact"].get<bool>()) << rest["restart"];
    EXPECT_EQ(rest["steps"], 100);
    EXPECT_EQ(rest["contacts_per_step"], full["contacts_per_step"]) << "the run's totals carry over";
    EXPECT_EQ(rest["diagnostics"]["max_penetration"], full["diagnostics"]["max_penetration"]);
}

INSTANTIATE_TEST_SUITE_P(
    Scenes, RestartEquals,
    ::testing::Values(Config{"parallel", "tennis.toml --set catoms.count=500 --collide grid --solver parallel"},
                      Config{"quickstep", "tennis.toml --set catoms.count=500 --collide ode-hash --solver ode"},
                      Config{"magnets", "magnetic-tennis.toml --set catoms.count=500 --collide grid --solver parallel"},
                      Config{"buggy", "buggy.toml"}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

TEST_F(Restart, CheckpointOfAnotherSceneIsRefused) {
    ASSERT_EQ(parode("run " + kScenes + "tennis.toml --set catoms.count=64 --steps 5 -q --checkpoint c.ckpt"), 0);
    EXPECT_EQ(parode("run " + kScenes + "tennis.toml --set catoms.count=65 --restart c.ckpt --steps 5 -q"), 2);
    EXPECT_NE(err().find("written for scene 'tennis'"), std::string::npos) << err();
    EXPECT_NE(err().find("same --set options"), std::string::npos) << err();
}

TEST_F(Restart, DamagedCheckpointIsRefused) {
    ASSERT_EQ(parode("run " + kScenes + "tennis.toml --set catoms.count=64 --steps 5 -q --checkpoint c.ckpt"), 0);
    fs::resize_file(dir_ / "c.ckpt", fs::file_size(dir_ / "c.ckpt") - 10);
    EXPECT_EQ(parode("run " + kScenes + "tennis.toml --set catoms.count=64 --restart c.ckpt --steps 5 -q"), 2);
    EXPECT_NE(err().find("truncated or damaged checkpoint"), std::string::npos) << err();
    std::ofstream(dir_ / "junk.ckpt") << "not a checkpoint\n";
    EXPECT_EQ(parode("run " + kScenes + "tennis.toml --set catoms.count=64 --restart junk.ckpt --steps 5 -q"), 2);
    EXPECT_NE(err().find("not a parode checkpoint"), std::string::npos) << err();
}

// SIGTERM a long run; it stops after a step with exit 7, a checkpoint and a
// report marked interrupted; 50 steps from the checkpoint equal a run that
// went straight to that step + 50.
TEST_F(Restart, SigtermWritesCheckpointAndInterruptedReport) {
    const std::string scene = kScenes + "tennis.toml --set catoms.count=500 --collide grid --solver parallel -q";
    const std::string cmd = "cd '" + dir_.string() + "' && ('" + PARODE_BINARY + "' run " + scene +
                            " --steps 1000000 --report int.json 2>stderr.txt & pid=$!; sleep 1; kill -TERM $pid; wait $pid;"
                            " echo $? >rc.txt)";
    ASSERT_EQ(std::system(cmd.c_str()), 0);
    std::ifstream rc(dir_ / "rc.txt");
    int code = -1;
    rc >> code;
    EXPECT_EQ(code, 7) << err();
    const nlohmann::json r = report("int.json");
    ASSERT_TRUE(r.contains("interrupted")) << r.dump();
    EXPECT_EQ(r["interrupted"]["signal"], "SIGTERM");
    const long step = r["interrupted"]["step"].get<long>();
    EXPECT_EQ(r["steps"].get<long>(), step);
    ASSERT_TRUE(fs::exists(dir_ / "tennis-interrupted.ckpt"));
    ASSERT_EQ(parode("run " + scene + " --restart tennis-interrupted.ckpt --steps 50 --report rest.json"), 0) << err();
    ASSERT_EQ(parode("run " + scene + " --steps " + std::to_string(step + 50) + " --report straight.json"), 0) << err();
    EXPECT_EQ(report("rest.json")["state_hash"], report("straight.json")["state_hash"]);
}

TEST_F(Restart, CheckpointEveryKStepsHoldsTheLatestStep) {
    ASSERT_EQ(parode("run " + kScenes + "tennis.toml --set catoms.count=64 --steps 25 -q --checkpoint c.ckpt "
                     "--checkpoint-every 10 --report r.json"), 0);
    std::ifstream in(dir_ / "c.ckpt");
    std::string magic, json;
    std::getline(in, magic);
    std::getline(in, json);
    EXPECT_EQ(nlohmann::json::parse(json)["step"], 25) << "the end of the run overwrites the step-20 checkpoint";
}

}  // namespace
