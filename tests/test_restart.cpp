// Checkpoint and restart, end to end through the parode command: a run of
// 2k steps equals a run of k steps restarted for k more, bit for bit (state
// hash, and the run's totals), on parode's solver, ODE's QuickStep (with its
// dRand state), dWorldStep with joints and a driver, and magnets; a
// checkpoint of another scene, or a damaged one, is refused with the reason;
// SIGTERM finishes the step, writes a checkpoint and a report marked
// interrupted, exits 7, and the checkpoint continues the run exactly; the
// impulse index sends a reader to the blocks that may hold its bodies'.
// Trade-off: real processes and files, small scenes (500 catoms, 200 steps).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "domain/collectives.hpp"
#include "io/checkpoint.hpp"
#include "binary.hpp"

namespace {

namespace fs = std::filesystem;

const std::string kScenes = std::string(PARODE_SOURCE_DIR) + "/jobs/scenes/";

class Restart : public parode::test::ScratchDirTest {
protected:
    Restart() : ScratchDirTest("restart") {}
    int parode(const std::string& args) const { return parode::test::run_parode({args, "", "", dir_, 0}).rc; }
    nlohmann::json report(const std::string& name) const { return parode::test::read_json(dir_ / name); }
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

// One process's file: the records and then the tail made piece by piece
// (two a piece), each run of consecutive ids inside a piece in one write;
// head, records by gid and tail byte for byte.
TEST(FilePieces, OneProcessWritesTheRecordsPieceByPiece) {
    const std::vector<std::uint32_t> gids{0, 1, 2, 4, 5, 7};
    const auto record = [](std::uint32_t g) { return std::string("r") + static_cast<char>('a' + g) + "-"; };
    parode::FilePieces f;
    f.head = {'h', 'd'};
    f.records_at = 2;
    f.record = 3;
    f.gids = gids;
    f.piece = 2;
    std::vector<std::size_t> sizes;
    f.pack = [&](std::size_t first, std::size_t n, char* out) {
        sizes.push_back(n);
        for (std::size_t k = 0; k < n; ++k) std::memcpy(out + 3 * k, record(gids[first + k]).data(), 3);
    };
    f.tail_at = 2 + 8 * 3;
    const std::string tail = "TUV";
    f.tail_count = tail.size();
    f.pack_tail = [&](std::size_t first, std::size_t n, char* out) {
        sizes.push_back(100 + n);
        std::memcpy(out, tail.data() + first, n);
    };
    const std::string path = (std::filesystem::temp_directory_path() / "parode_file_pieces.bin").string();
    parode::Collectives().write_file(path, f);
    EXPECT_EQ(sizes, (std::vector<std::size_t>{2, 2, 2, 102, 101}));
    std::ifstream in(path, std::ios::binary);
    std::string got((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    got.replace(2 + 3 * 3, 3, "...").replace(2 + 6 * 3, 3, "...");  // ids 3 and 6: held by nobody, never written
    EXPECT_EQ(got, "hd" + record(0) + record(1) + record(2) + "..." + record(4) + record(5) + "..." + record(7) + "TUV");
    std::filesystem::remove(path);
}

TEST_F(Restart, CheckpointOfAnotherSceneIsRefused) {
    ASSERT_EQ(parode("run " + kScenes + "tennis.toml --set catoms.count=64 --steps 5 -q --checkpoint c.ckpt"), 0);
    EXPECT_EQ(parode("run " + kScenes + "tennis.toml --set catoms.count=65 --restart c.ckpt --steps 5 -q"), 2);
    EXPECT_NE(err().find("written for scene 'tennis'"), std::string::npos) << err();
    EXPECT_NE(err().find("same --set options"), std::string::npos) << err();
}

TEST_F(Restart, DamagedCheckpointIsRefused) {
    const std::string run = "run " + kScenes + "tennis.toml --set catoms.count=64 --steps 5 -q";
    ASSERT_EQ(parode(run + " --checkpoint c.ckpt"), 0);
    const std::string good = parode::test::slurp(dir_ / "c.ckpt");
    const parode::Checkpoint c = parode::read_checkpoint((dir_ / "c.ckpt").string());
    fs::resize_file(dir_ / "c.ckpt", fs::file_size(dir_ / "c.ckpt") - 10);
    EXPECT_EQ(parode(run + " --restart c.ckpt"), 8);
    EXPECT_NE(err().find("damaged checkpoint: truncated"), std::string::npos) << err();
    ASSERT_GT(c.impulses, 0u);
    struct Damage {
        std::uint64_t at;
        const char* message;
    };
    const Damage cases[] = {
        {good.find("\"count\":") + 8, "header checksum"},
        {c.head_bytes + 20 * parode::kRecordBytes + 3, "the records of bodies 0 to 63: checksum"},
        {good.size() - 3, "the impulses written by process 0"},
        {4, "not a parode checkpoint, or a damaged one"},
    };
    for (const Damage& d : cases) {
        std::string bytes = good;
        bytes[d.at] = static_cast<char>(bytes[d.at] ^ 0x10);
        std::ofstream(dir_ / "d.ckpt", std::ios::binary) << bytes;
        EXPECT_EQ(parode(run + " --restart d.ckpt"), 8) << "byte " << d.at;
        EXPECT_NE(err().find(d.message), std::string::npos) << err();
        EXPECT_NE(err().find("d.ckpt.prev"), std::string::npos) << "the message points at the kept one";
    }
    std::ofstream(dir_ / "junk.ckpt") << "not a checkpoint\n";
    EXPECT_EQ(parode(run + " --restart junk.ckpt"), 8);
    EXPECT_NE(err().find("not a parode checkpoint"), std::string::npos) << err();
}

// Single bits flipped at random offsets (seeded) anywhere in a checkpoint
// with impulses: every one is refused with exit 8, none runs on.
TEST_F(Restart, EveryFlippedByteIsRefused) {
    const std::string run = "run " + kScenes + "tennis.toml --set catoms.count=64 --steps 5 -q";
    ASSERT_EQ(parode(run + " --checkpoint c.ckpt --report r.json"), 0);
    const std::string good = parode::test::slurp(dir_ / "c.ckpt");
    ASSERT_EQ(parode(run + " --restart c.ckpt --report ok.json"), 0) << err();
    const nlohmann::json checked = report("ok.json")["restart"]["checked"];
    EXPECT_TRUE(checked["verified"].get<bool>()) << checked;
    EXPECT_EQ(checked["record_blocks"], 1);
    EXPECT_EQ(checked["impulse_pieces"], 1);
    std::mt19937_64 rng(20261127);
    const parode::Checkpoint c = parode::read_checkpoint((dir_ / "c.ckpt").string());
    const std::uint64_t sections[][2] = {{0, c.head_bytes},
                                         {c.head_bytes, c.head_bytes + c.bodies * parode::kRecordBytes},
                                         {c.head_bytes + c.bodies * parode::kRecordBytes, good.size()}};
    for (int k = 0; k < 30; ++k) {
        const auto& s = sections[k % 3];
        const std::uint64_t at = s[0] + rng() % (s[1] - s[0]);
        std::string bytes = good;
        bytes[at] = static_cast<char>(bytes[at] ^ (1 << (rng() % 8)));
        std::ofstream(dir_ / "d.ckpt", std::ios::binary) << bytes;
        EXPECT_EQ(parode(run + " --restart d.ckpt"), 8) << "byte " << at << ": " << err();
    }
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

// The impulse index of a checkpoint: a reader reads only the blocks whose
// lower-id range holds one of its bodies, neighbouring blocks joined, across
// the writers' pieces (an empty piece included).
TEST(ImpulseIndex, ReadsOnlyTheBlocksThatMayHoldTheBodies) {
    const nlohmann::json index = {
        {"block", 4},
        {"pieces",
         {{{"count", 10}, {"lo", {0, 3, 4, 9, 20, 21}}},  // impulses [0, 4), [4, 8), [8, 10)
          {{"count", 0}, {"lo", nlohmann::json::array()}},
          {{"count", 6}, {"lo", {10, 19, 22, 30}}}}}};  // impulses [10, 14), [14, 16)
    using Ranges = std::vector<std::pair<std::uint64_t, std::uint64_t>>;
    const auto ranges = [&index](const std::vector<std::uint32_t>& gids) {
        Ranges r;
        for (const parode::ImpulseRange& x : parode::impulse_ranges(index, gids)) r.emplace_back(x.first, x.count);
        return r;
    };
    EXPECT_EQ(ranges({}), Ranges{});
    EXPECT_EQ(ranges({31, 40}), Ranges{});
    EXPECT_EQ(ranges({5}), (Ranges{{4, 4}}));
    EXPECT_EQ(ranges({3, 4}), (Ranges{{0, 8}}));
    EXPECT_EQ(ranges({21, 22}), (Ranges{{8, 2}, {14, 2}}));
    EXPECT_EQ(ranges({10, 20}), (Ranges{{8, 6}}));
    std::vector<std::uint32_t> all(41);
    for (std::uint32_t g = 0; g < all.size(); ++g) all[g] = g;
    EXPECT_EQ(ranges(all), (Ranges{{0, 16}}));
}
