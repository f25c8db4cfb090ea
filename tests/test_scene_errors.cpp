// Scene-file validation: every malformed file in tests/data/bad/ must throw
// SceneError naming the file, the line, the dotted key and what was expected;
// `--set` overrides go through the same checks; a good override builds the prism.
// Trade-off: expected messages are matched as substrings written out in the
// table below, so rewording a message means editing this table, but a vague or
// misplaced message fails here instead of reaching a user.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "scene/scene_file.hpp"
#include "util/split_mix.hpp"

namespace {

namespace fs = std::filesystem;

const std::string kSourceDir = PARODE_SOURCE_DIR;
const std::string kBadDir = kSourceDir + "/tests/data/bad/";
const std::string kTennis = kSourceDir + "/jobs/scenes/tennis.toml";

struct BadCase {
    const char* file;      // in tests/data/bad/
    int line;              // 0: the message has no meaningful line
    const char* key;       // dotted key, quoted in the message; "" when none
    const char* expected;  // what the message says was expected
    const char* extra;     // a further substring ("" for none)
};

const BadCase kBadCases[] = {
    {"syntax_error.toml", 3, "", "TOML syntax error", "name = \"syntax"},
    {"duplicate_key.toml", 5, "", "TOML syntax error", "value (\"dt\") already exists"},
    {"no_scene.toml", 0, "scene", "missing required key", ""},
    {"no_name.toml", 2, "scene.name", "expected a non-empty string", ""},
    {"dt_string.toml", 4, "scene.dt", "expected a number in [1e-09, 1]", "got the string \"fast\""},
    {"bad_dt.toml", 7, "scene.dt", "expected a number in [1e-09, 1]", "got -0.005"},
    {"zero_catoms.toml", 6, "catoms.count", "expected an integer in [1, 100000000]", "got 0"},
    {"count_float.toml", 6, "catoms.count", "expected an integer in [1, 100000000]", "got 8.5"},
    {"bad_erp.toml", 6, "solver.erp", "expected a number in [0, 1]", "got 2"},
    {"typo_key.toml", 6, "catoms.cuont",
     "(expected one of: count, radius, mass, layout, spacing, jitter, material, base, velocity)", "unknown key"},
    {"unknown_material.toml", 10, "bodies[0].material", "expected the name of a material (ball)",
     "got the string \"steel\""},
    {"unknown_catom_material.toml", 10, "catoms.material", "expected the name of a material (ball)",
     "got the string \"rubber\""},
    {"materials_table.toml", 5, "materials", "expected an array", "got a table"},
    {"joint_unknown_body.toml", 10, "joints[0].bodies", "expected the name of a body or \"world\"",
     "got the string \"ghost\""},
    {"gravity_2.toml", 4, "scene.gravity", "expected an array of 3 numbers", "got an array of 2 elements"},
    {"bad_shape.toml", 7, "bodies[0].shape", "expected one of \"sphere\", \"box\", \"capsule\", \"cylinder\"",
     "got the string \"cube\""},
    {"bad_joint_param.toml", 11, "joints[0].params.lo_stp", "expected one of: lo_stop, hi_stop, vel",
     "unknown joint parameter"},
    {"bad_stepper.toml", 6, "solver.stepper", "expected one of \"quick\", \"world\"", "got the string \"fast\""},
    {"magnets_off_noncatom.toml", 13, "magnets.off[1]", "expected the id of a catom body (catoms are bodies 1 to 8)",
     "got 0"},
    {"substeps_few_iterations.toml", 7, "solver.iterations",
     "expected at least 3 when solver.substeps > 1 and solver.sor_w > 1 (over-relaxed, fewer sweeps a substep "
     "overshoot a bounce", "got 2"},
    {"substeps_with_magnets.toml", 6, "solver.substeps",
     "expected 1 while [magnets] are on (the magnet forces are computed once a step", "got 4"},
    {"duplicate_body.toml", 9, "bodies[1].name", "expected a name not used by another body",
     "got the string \"a\""},
    {"no_bodies.toml", 0, "", "the scene has no bodies (add [[bodies]] or [catoms])", ""},
    // Magnitudes ODE cannot represent (scene/limits.hpp).
    {"huge_position.toml", 10, "statics[0].position", "expected an array of 3 numbers, each in [-1e+06, 1e+06] (m)",
     "got [0, 0, 1e+20]"},
    {"huge_gravity.toml", 4, "scene.gravity", "expected an array of 3 numbers of length <= 1000 (m/s^2)",
     "got [0, 0, 9.2e+18]"},
    {"huge_mass.toml", 7, "bodies[0].mass", "expected a number in [1e-06, 1e+06]", "got 1e+300"},
    {"huge_velocity.toml", 7, "bodies[0].velocity",
     "expected an array of 3 numbers of length <= 2000 (m/s: at most 10 m per step of dt = 0.005 s)",
     "got [1e+200, 0, 0]"},
    {"overflow_literal.toml", 5, "scene.dt", "expected a number in [1e-09, 1]", "got 1e309 (beyond the range of a double)"},
    {"overflow_integer.toml", 6, "catoms.count", "expected an integer in [1, 100000000]",
     "got 99999999999999999999 (beyond the range of a 64-bit integer)"},
    {"mass_ratio.toml", 11, "bodies[1].mass", "expected a mass at most 1e+06 times the lightest body's",
     "(bodies[0] 'feather', 1e-06 kg), got 1e+06"},
    {"tiny_radius.toml", 7, "bodies[0].radius", "expected a number in [0.0001, 10000]", "got 1e-09"},
    {"hinge2_parallel.toml", 16, "joints[0].axis2", "expected a vector not parallel to axis1",
     "got an array of 3 elements [0.0, 0.0, -2.0]"},
    {"joint_self.toml", 10, "joints[0].bodies", "expected two different bodies", "[\"a\", \"a\"]"},
    {"joint_erp.toml", 15, "joints[0].params.suspension_erp", "expected a number in [0, 1]", "got 1e+07"},
    {"prism_extent.toml", 8, "catoms.spacing", "expected a prism inside the coordinate bound (|x|, |y|, |z| <= 1e+06 m)",
     "reaches 1.004e+06 m"},
    {"guard_speed.toml", 9, "guard.max_speed", "expected a number in [1e-09, 2000]", "got 1e+09"},
    {"zero_axis.toml", 11, "joints[0].axis1", "expected a non-zero vector", "[0.0, 0.0, 0.0]"},
};

// The SceneError message of loading `path`, or a failure when it does not throw one.
std::string scene_error(const std::string& path, const std::vector<std::string>& sets = {}) {
    try {
        const parode::Scene sc = parode::load_scene(path, sets);
        ADD_FAILURE() << path << " loaded without error (" << sc.body_count() << " bodies)";
    } catch (const parode::SceneError& e) {
        return e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << path << " threw something other than SceneError: " << e.what();
    }
    return "";
}

class BadScene : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadScene, MessageNamesFileLineKeyAndExpectation) {
    const BadCase& c = GetParam();
    const std::string msg = scene_error(kBadDir + c.file);
    SCOPED_TRACE("message: " + msg);
    EXPECT_NE(msg.find(c.file), std::string::npos) << "file name missing";
    if (c.line > 0) {
        const std::string at = std::string(c.file) + ":" + std::to_string(c.line) + ":";
        EXPECT_NE(msg.find(at), std::string::npos) << "expected location " << at;
    }
    if (*c.key) {
        EXPECT_NE(msg.find("'" + std::string(c.key) + "'"), std::string::npos) << "key missing";
    }
    EXPECT_NE(msg.find(c.expected), std::string::npos) << "expected-value text missing";
    if (*c.extra) {
        EXPECT_NE(msg.find(c.extra), std::string::npos) << "missing: " << c.extra;
    }
}

std::string case_name(const ::testing::TestParamInfo<BadCase>& info) {
    std::string n = fs::path(info.param.file).stem().string();
    for (char& ch : n) if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
    return n;
}

INSTANTIATE_TEST_SUITE_P(BadFiles, BadScene, ::testing::ValuesIn(kBadCases), case_name);

TEST(BadSceneTable, EveryFileInTheFolderHasACase) {
    std::set<std::string> listed;
    for (const BadCase& c : kBadCases) listed.insert(c.file);
    std::set<std::string> on_disk;
    for (const auto& e : fs::directory_iterator(kBadDir)) {
        if (e.path().extension() == ".toml") on_disk.insert(e.path().filename().string());
    }
    EXPECT_EQ(on_disk, listed);
    EXPECT_GE(on_disk.size(), 12u);
}

TEST(SceneOverride, BadValueNamesKeyAndSet) {
    const std::string msg = scene_error(kTennis, {"catoms.count=0"});
    EXPECT_NE(msg.find("--set catoms.count=0"), std::string::npos) << msg;
    EXPECT_NE(msg.find("'catoms.count'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("expected an integer in [1, 100000000], got 0"), std::string::npos) << msg;
    EXPECT_EQ(msg.find("tennis.toml"), std::string::npos) << "the value came from --set, not the file: " << msg;
}

struct BadSet {
    const char* assignment;
    const char* expected;
};

class BadOverride : public ::testing::TestWithParam<BadSet> {};

TEST_P(BadOverride, IsASceneErrorNamingTheSet) {
    const BadSet& c = GetParam();
    const std::string msg = scene_error(kTennis, {c.assignment});
    EXPECT_NE(msg.find(std::string("--set ") + c.assignment), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.expected), std::string::npos) << msg;
}

INSTANTIATE_TEST_SUITE_P(
    Sets, BadOverride,
    ::testing::Values(BadSet{"catoms.count", "expected key=value"},
                      BadSet{"scene.dt=fast", "key 'scene.dt': expected a number in [1e-09, 1], got the string \"fast\""},
                      BadSet{"catoms.cuont=8", "unknown key 'catoms.cuont'"},
                      BadSet{"foo.bar=1", "unknown key 'foo'"},
                      BadSet{"scene.=1", "empty key segment"},
                      BadSet{"materials.x.mu=1", "'x' is not an array index"},
                      BadSet{"materials.99999999999999999999999.mu=1", "is not an array index"},
                      BadSet{"materials.5.mu=1", "index 5 out of range (the array has 1 elements)"},
                      BadSet{"materials.0.mu=-1", "key 'materials[0].mu': expected a number >= 0, got -1"},
                      BadSet{"scene.name=\"abc", "the value is not valid TOML"},
                      BadSet{"scene.name.x=1", "the parent of 'x' is not a table"}));

// Overflowing literals from --set are caught as in files.
TEST(SceneOverride, OverflowingLiteralIsAnError) {
    const std::string msg = scene_error(kTennis, {"scene.gravity=[0, 0, -1e309]"});
    EXPECT_NE(msg.find("--set scene.gravity=[0, 0, -1e309]: key 'scene.gravity[2]': expected a number, got -1e309 "
                       "(beyond the range of a double)"),
              std::string::npos)
        << msg;
    const std::string tiny = scene_error(kTennis, {"catoms.radius=1e-400"});
    EXPECT_NE(tiny.find("got 1e-400 (too small for a double)"), std::string::npos) << tiny;
}

// Within the bounds, extreme but valid values load, and the guard takes the
// speed bound of the scene's dt.
TEST(SceneBounds, ValuesAtTheBoundsLoad) {
    const parode::Scene sc = parode::load_scene(
        kTennis, {"catoms.count=8", "catoms.base=[0, 0, 999000]", "catoms.mass=1e6", "catoms.velocity=[2000, 0, 0]",
                  "scene.gravity=[0, 0, -1000]", "catoms.radius=0.0001", "catoms.spacing=0.0001"});
    EXPECT_EQ(sc.body_count(), 8u);
    EXPECT_DOUBLE_EQ(sc.guard.max_speed, 2000.0);
    const parode::Scene slow = parode::load_scene(kTennis, {"catoms.count=8", "scene.dt=0.01"});
    EXPECT_DOUBLE_EQ(slow.guard.max_speed, 1000.0);
}

TEST(SceneOverride, LaterSetWins) {
    const parode::Scene sc = parode::load_scene(kTennis, {"catoms.count=0", "catoms.count=8"});
    EXPECT_EQ(sc.body_count(), 8u);
}

TEST(SceneOverride, BareWordIsAString) {
    const parode::Scene sc = parode::load_scene(kTennis, {"scene.name=renamed", "catoms.count=8"});
    EXPECT_EQ(sc.name, "renamed");
}

// catoms.count=27 -> a 3 x 3 x 3 prism of touching balls (radius 0.5, spacing 1)
// centred on x = y = 0 and standing on z = 0, each moved by at most the jitter.
TEST(SceneOverride, CountBuildsAPrism) {
    const parode::Scene sc = parode::load_scene(kTennis, {"catoms.count=27"});
    ASSERT_EQ(sc.body_count(), 27u);
    const double r = 0.5, jitter = 0.01 * r, tol = jitter + 1e-12;
    std::set<std::tuple<int, int, int>> cells;
    double zmin = 1e9;
    for (std::size_t id = 0; id < sc.body_count(); ++id) {
        const parode::BodySpec b = sc.body(id);
        EXPECT_TRUE(b.catom);
        EXPECT_EQ(b.shape.kind, parode::ShapeKind::Sphere);
        EXPECT_DOUBLE_EQ(b.shape.radius, r);
        const double gx = std::round(b.position[0]), gy = std::round(b.position[1]);
        const double gz = std::round(b.position[2] - r);
        EXPECT_NEAR(b.position[0], gx, tol);
        EXPECT_NEAR(b.position[1], gy, tol);
        EXPECT_NEAR(b.position[2], gz + r, tol);
        cells.insert({static_cast<int>(gx), static_cast<int>(gy), static_cast<int>(gz)});
        zmin = std::min(zmin, b.position[2]);
    }
    EXPECT_EQ(cells.size(), 27u) << "every lattice cell holds exactly one ball";
    for (const auto& [i, j, k] : cells) {
        EXPECT_TRUE(i >= -1 && i <= 1 && j >= -1 && j <= 1 && k >= 0 && k <= 2) << i << " " << j << " " << k;
    }
    EXPECT_NEAR(zmin, r, tol) << "the lowest catom sits on the floor";
}

// Catoms are generated by id on demand: catom n gets draws 3n .. 3n+2 of the
// seeded stream, exactly what one sequential pass over all catoms draws.
TEST(SceneOverride, CatomsByIdEqualOneSequentialPass) {
    const parode::Scene sc = parode::load_scene(kTennis, {"catoms.count=64", "scene.seed=7"});
    parode::SplitMix64 rng(7);
    const parode::CatomBlock& c = sc.catoms;
    for (std::size_t n = 0; n < 64; ++n) {
        const long i = static_cast<long>(n) % c.dims[0], j = (static_cast<long>(n) / c.dims[0]) % c.dims[1];
        const long k = static_cast<long>(n) / (c.dims[0] * c.dims[1]);
        const double x[3] = {(i - 0.5 * (c.dims[0] - 1)) * c.spacing, (j - 0.5 * (c.dims[1] - 1)) * c.spacing,
                             0.5 + k * c.spacing};
        const parode::Vec3 p = sc.body(c.first + n).position;
        for (int a = 0; a < 3; ++a) ASSERT_EQ(p[a], x[a] + (2 * rng.uniform() - 1) * c.jitter) << "catom " << n;
    }
}

TEST(SceneFile, MissingFileIsAClearError) {
    const std::string path = kSourceDir + "/tests/data/no_such_scene.toml";
    const std::string msg = scene_error(path);
    EXPECT_NE(msg.find(path + ": cannot open scene file"), std::string::npos) << msg;
    EXPECT_NE(msg.find("No such file or directory"), std::string::npos) << msg;
}

TEST(SceneFile, DirectoryIsAClearError) {
    const std::string msg = scene_error(kBadDir);
    EXPECT_NE(msg.find("cannot open scene file (it is a directory)"), std::string::npos) << msg;
}

TEST(SceneText, SyntaxErrorHasNameAndLine) {
    try {
        parode::load_scene_text("[scene]\nname = \"x\"\ndt = 0.1 0.2\n", "inline.toml");
        FAIL() << "no error";
    } catch (const parode::SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("inline.toml:3: TOML syntax error"), std::string::npos) << e.what();
    }
}

// The shipped scenes load: the checks above do not reject good files.
TEST(SceneFile, ExampleScenesLoad) {
    const parode::Scene tennis = parode::load_scene(kTennis);
    EXPECT_EQ(tennis.name, "tennis");
    EXPECT_EQ(tennis.body_count(), 1000u);
    const parode::Scene magnetic = parode::load_scene(kSourceDir + "/jobs/scenes/magnetic-tennis.toml");
    EXPECT_TRUE(magnetic.magnets.enabled);
    const parode::Scene buggy = parode::load_scene(kSourceDir + "/jobs/scenes/buggy.toml");
    EXPECT_EQ(buggy.body_count(), 4u);
    EXPECT_EQ(buggy.joints.size(), 3u);
    EXPECT_TRUE(buggy.controller.path == parode::DrivePath::FigureEight);
    EXPECT_EQ(buggy.controller.chassis, 0);  // first body of the steered joint
    EXPECT_DOUBLE_EQ(buggy.controller.start[2], 0.5);
    const parode::Scene fast = parode::load_scene(kSourceDir + "/jobs/scenes/hard/buggy-fast.toml");
    EXPECT_TRUE(fast.controller.path == parode::DrivePath::Straight);
}

// Who partitions the cells is one of three names; anything else names the key.
TEST(SceneOverride, PartitionerIsChecked) {
    const std::string tennis = kSourceDir + "/jobs/scenes/tennis.toml";
    const std::string msg = scene_error(tennis, {"parallel.partitioner=\"scotch\""});
    EXPECT_NE(msg.find("parallel.partitioner"), std::string::npos) << msg;
    EXPECT_NE(msg.find("expected one of \"best\", \"metis\", \"bisection\""), std::string::npos) << msg;
    EXPECT_EQ(parode::load_scene(tennis, {"parallel.partitioner=\"bisection\""}).parallel.partitioner, "bisection");
}

// The driver's table is checked like the others: an unknown path type, or a key
// of an older driver, names the key and what is accepted.
TEST(SceneOverride, ControllerKeysAreChecked) {
    const std::string buggy = kSourceDir + "/jobs/scenes/buggy.toml";
    std::string msg = scene_error(buggy, {"controller.type=\"loop\""});
    EXPECT_NE(msg.find("expected one of \"figure-eight\", \"straight\""), std::string::npos) << msg;
    msg = scene_error(buggy, {"controller.period=12.0"});
    EXPECT_NE(msg.find("unknown key 'controller.period'"), std::string::npos) << msg;
    msg = scene_error(buggy, {"controller.speed_min=-1.0"});
    EXPECT_NE(msg.find("'controller.speed_min': expected a number in [0, 10000]"), std::string::npos) << msg;
}

}  // namespace
