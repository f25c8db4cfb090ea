// The `parode` command line, end to end: runs the built executable (PARODE_BINARY)
// through the shell and checks exit codes, error messages, the JSON run report
// and that the state hash is reproducible and depends on the seed.
// Trade-off: real processes on real scene files test what a user sees (option
// parsing, the error guard, file output) at the cost of a process start per
// check, so every run is tiny (8 catoms, 20 steps) and the whole file takes ~1 s.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

const std::string kSourceDir = PARODE_SOURCE_DIR;
const std::string kTennis = kSourceDir + "/jobs/scenes/tennis.toml";
const std::string kMagnetic = kSourceDir + "/jobs/scenes/magnetic-tennis.toml";
const std::string kSmall = " --set catoms.count=8 --steps 20 --threads 1 -q";

struct Result {
    int rc = -1;
    std::string out;
    std::string err;
};

std::string slurp(const fs::path& p) {
    std::ifstream in(p);
    std::ostringstream os;
    os << in.rdbuf();
    return os.str();
}

class Cli : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("parode_test_cli_" + std::to_string(::getpid()));
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    // `parode ARGS` with stdout and stderr captured separately.
    Result parode(const std::string& args) const {
        const fs::path out = dir_ / "stdout.txt", err = dir_ / "stderr.txt";
        const std::string cmd = std::string("'") + PARODE_BINARY + "' " + args + " >'" + out.string() + "' 2>'" +
                                err.string() + "'";
        const int status = std::system(cmd.c_str());
        Result r;
        r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        r.out = slurp(out);
        r.err = slurp(err);
        return r;
    }

    // Runs a small simulation of `scene` and returns its parsed report.
    nlohmann::json report(const std::string& scene, const std::string& extra = "") const {
        const fs::path path = dir_ / "report.json";
        fs::remove(path);
        const Result r = parode("run '" + scene + "'" + kSmall + extra + " --report '" + path.string() + "'");
        EXPECT_EQ(r.rc, 0) << r.err;
        EXPECT_TRUE(fs::exists(path)) << r.err;
        return nlohmann::json::parse(slurp(path));  // throws (fails the test) unless valid JSON
    }

    fs::path dir_;
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
    EXPECT_NEAR(j.at("ms_per_step").get<double>(), 1000.0 * j.at("wall_s").get<double>() / 20, 1e-9);
    for (const char* s : {"forces", "collide", "joints", "solve", "observe", "output"}) {
        ASSERT_TRUE(j.at("stages").contains(s)) << s;
        EXPECT_GE(j["stages"][s].get<double>(), 0.0) << s;
        EXPECT_TRUE(j.at("stages_run").contains(s)) << s;
    }
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

TEST_F(Cli, StagesRunFollowTheScene) {
    const nlohmann::json plain = report(kTennis);
    EXPECT_EQ(plain.at("stages_run").at("forces").at("ran"), false);
    EXPECT_EQ(plain["stages_run"]["collide"]["ran"], true);
    const nlohmann::json magnetic = report(kMagnetic);
    EXPECT_EQ(magnetic.at("scene"), "magnetic-tennis");
    EXPECT_EQ(magnetic.at("stages_run").at("forces").at("ran"), true);
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
    EXPECT_TRUE(report(kTennis).at("substages").empty()) << "ODE's space and stepper have no substages";
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

TEST_F(Cli, StateHashIsReproducibleAndSeeded) {
    const std::string first = report(kTennis).at("state_hash");
    const std::string again = report(kTennis).at("state_hash");
    const std::string reseeded = report(kTennis, " --set scene.seed=2").at("state_hash");
    EXPECT_EQ(first, again);
    EXPECT_NE(first, reseeded);
}

}  // namespace
