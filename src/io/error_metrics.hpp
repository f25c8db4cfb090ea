// Error of a run against a reference run of the same scene (smaller dt, more
// iterations, or dWorldStep), from two trajectories matched by simulated time.
// Metrics that stay meaningful for chaotic piles: short-horizon trajectory error
// (RMS and max position error after k steps), penetration, energy and momentum
// drift, and long-horizon observables of the pile (centre-of-mass height,
// horizontal spread, catoms that left the initial footprint, shape drift and
// shape error of the pile about its centroid).
// Trade-off: per-body position error is only meaningful before chaos sets in,
// so it is reported at short horizons; after that, only the observables of the
// pile as a whole are compared.
#pragma once
#include <nlohmann/json.hpp>

#include <utility>
#include <vector>

#include "io/trajectory.hpp"

namespace parode {

struct PositionError {
    double rms = 0, max = 0;
};

// Observables of a frame; the selection is the catoms, or every body if none.
struct PileObservables {
    double com_height = 0;   // mass-weighted, from the frame's diagnostics
    double spread = 0;       // RMS horizontal distance from the horizontal centroid
    double escaped = 0;      // selected bodies outside the initial footprint (+ one radius)
    double shape_drift = 0;  // RMS change of position about the centroid since the first frame
};

std::vector<char> selection(const Trajectory& t);
PositionError position_error(const Frame& a, const Frame& b);
// RMS over the selection of |(a_i - centroid a) - (b_i - centroid b)|.
double shape_error(const Frame& a, const Frame& b, const std::vector<char>& sel);
PileObservables observables(const Trajectory& t, const Frame& f);
// (run frame, reference frame) index pairs of equal simulated time.
std::vector<std::pair<std::size_t, std::size_t>> match_frames(const Trajectory& run, const Trajectory& ref);

// The `error` block of the run report (README "Speed against error"). Throws std::runtime_error when the two
// trajectories are not of the same scene (body count) or share no frame.
nlohmann::json compare_trajectories(const Trajectory& run, const Trajectory& ref,
                                    const std::vector<long>& horizons = {10, 50, 200});

}  // namespace parode
