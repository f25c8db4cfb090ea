// Error against a reference: the metrics on hand-made frames with known
// answers (RMS and max position error, matching by simulated time, spread,
// escaped catoms, shape error), the trajectory file round trip, and real runs:
// a run compared with itself has zero error, and on a short horizon a larger
// dt is further from a dt/4, 100-iteration reference than a smaller one.
// Trade-off: the real runs use 125 catoms and 0.25 s so the file takes ~2 s.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "io/error_metrics.hpp"
#include "test_support.hpp"

using namespace parode;

namespace {

Frame frame(long step, double time, std::vector<double> xyz) {
    Frame f;
    f.step = step;
    f.time = time;
    f.positions = std::move(xyz);
    return f;
}

Trajectory four_bodies(double dt) {
    Trajectory t;
    t.catom = {1, 1, 1, 1};
    t.catom_radius = 0.5;
    t.meta = {{"dt", dt}, {"scene", "four"}, {"solver", {{"stepper", "quick"}, {"iterations", 20}}}};
    return t;
}

const std::vector<double> kSquare = {0, 0, 0.5, 1, 0, 0.5, 0, 1, 0.5, 1, 1, 0.5};

TEST(ErrorMetrics, PositionErrorRmsAndMax) {
    std::vector<double> moved = kSquare;
    moved[3 * 2 + 0] += 0.3;
    moved[3 * 2 + 1] += 0.4;  // body 2 off by 0.5 m
    const PositionError e = position_error(frame(0, 0, moved), frame(0, 0, kSquare));
    EXPECT_DOUBLE_EQ(e.max, 0.5);
    EXPECT_DOUBLE_EQ(e.rms, 0.25);  // sqrt(0.25 / 4)
}

TEST(ErrorMetrics, FramesAreMatchedBySimulatedTime) {
    Trajectory run = four_bodies(0.01), ref = four_bodies(0.0025);
    for (int s = 0; s <= 3; ++s) run.frames.push_back(frame(10 * s, 0.1 * s, kSquare));
    for (int s = 0; s <= 13; ++s) ref.frames.push_back(frame(10 * s, 0.025 * s, kSquare));
    const auto m = match_frames(run, ref);
    ASSERT_EQ(m.size(), 4u);
    EXPECT_EQ(m[1], (std::pair<std::size_t, std::size_t>{1, 4}));
    EXPECT_EQ(m[3], (std::pair<std::size_t, std::size_t>{3, 12}));
}

TEST(ErrorMetrics, SpreadEscapedAndShape) {
    Trajectory t = four_bodies(0.01);
    t.frames.push_back(frame(0, 0, kSquare));
    std::vector<double> later = kSquare;
    later[0] = -3.0;  // body 0 rolled 3 m away in -x: outside the footprint [-0.5, 1.5]
    const PileObservables o = observables(t, frame(100, 1, later));
    EXPECT_DOUBLE_EQ(o.escaped, 1.0);
    EXPECT_GT(o.spread, observables(t, t.frames.front()).spread);
    EXPECT_DOUBLE_EQ(observables(t, t.frames.front()).shape_drift, 0.0);
    // A rigid translation is no shape error.
    std::vector<double> shifted = kSquare;
    for (std::size_t i = 0; i < shifted.size(); i += 3) shifted[i] += 7.0;
    EXPECT_NEAR(shape_error(frame(0, 0, shifted), frame(0, 0, kSquare), selection(t)), 0.0, 1e-12);
}

TEST(ErrorMetrics, DifferentScenesAreRejected) {
    Trajectory a = four_bodies(0.01), b = four_bodies(0.01);
    b.catom.push_back(1);
    a.frames.push_back(frame(0, 0, kSquare));
    b.frames.push_back(frame(0, 0, std::vector<double>(15, 0.0)));
    EXPECT_THROW(compare_trajectories(a, b), std::runtime_error);
}

Scene small_tennis(const std::vector<std::string>& sets) {
    std::vector<std::string> all = {"catoms.count=125"};
    all.insert(all.end(), sets.begin(), sets.end());
    return test::repo_scene("jobs/scenes/tennis.toml", all);
}

Trajectory record(const Scene& sc, double duration) {
    RunOptions opt;
    opt.record_trajectory = true;
    Pipeline p(sc, opt);
    const int steps = static_cast<int>(std::llround(duration / sc.dt));
    for (int s = 0; s < steps; ++s) p.step();
    p.finish();
    return *p.trajectory();
}

TEST(ErrorMetrics, TrajectoryFileRoundTrip) {
    const Trajectory t = record(small_tennis({}), 0.1);
    const std::string path = (std::filesystem::temp_directory_path() / "parode_test.traj").string();
    write_trajectory(path, t);
    ASSERT_TRUE(is_trajectory_file(path));
    const Trajectory back = read_trajectory(path);
    ASSERT_EQ(back.frames.size(), t.frames.size());
    EXPECT_EQ(back.catom, t.catom);
    EXPECT_EQ(back.frames.back().positions, t.frames.back().positions);
    EXPECT_EQ(back.frames.back().kinetic, t.frames.back().kinetic);
    std::filesystem::remove(path);
}

TEST(ErrorMetrics, RunAgainstItselfHasZeroError) {
    const Trajectory t = record(small_tennis({}), 0.25);
    const nlohmann::json e = compare_trajectories(t, t);
    EXPECT_EQ(e["final"]["rms"].get<double>(), 0.0);
    EXPECT_EQ(e["observables"]["shape_error"].get<double>(), 0.0);
    EXPECT_EQ(e["energy"]["max_abs_diff"].get<double>(), 0.0);
}

// Short horizon (0.05 s, before the pile turns chaotic): error shrinks with dt.
TEST(ErrorMetrics, SmallerDtIsCloserToTheReference) {
    const Trajectory ref = record(small_tennis({"scene.dt=0.00125", "solver.iterations=100"}), 0.25);
    auto error_at = [&](const std::string& dt) {
        const nlohmann::json e = compare_trajectories(record(small_tennis({"scene.dt=" + dt}), 0.25), ref);
        const auto& s = e["series"];
        for (std::size_t i = 0; i < s["time"].size(); ++i) {
            if (s["time"][i].get<double>() >= 0.05 - 1e-9) return s["rms"][i].get<double>();
        }
        return -1.0;
    };
    const double coarse = error_at("0.01"), fine = error_at("0.0025");
    EXPECT_GT(fine, 0.0);
    EXPECT_LT(fine, coarse) << "dt 0.0025: " << fine << " m, dt 0.01: " << coarse << " m";
}

}  // namespace
