// Trajectory files: the position of every body at observed steps, with the
// per-frame diagnostics the error metrics need (energy, momenta, centre-of-mass
// height, penetration, sleeping bodies). Frames carry their simulated time, so
// a reference run with a smaller dt is matched to a run by time, not by step.
// Format: one text line "parode-trajectory 1 <JSON metadata>\n", then per frame
// kFrameHeader doubles followed by x, y, z of every body (native doubles,
// little-endian on every machine parode runs on; the magic line is checked).
// Trade-off: positions only (24 bytes per body per frame), no orientations or
// velocities: enough for trajectory error and pile observables, small enough
// that a dt/4 reference of 1,000 catoms stays a few megabytes.
#pragma once
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "domain/collectives.hpp"
#include "util/errors.hpp"  // write_trajectory throws it
#include "observe/diagnostics.hpp"
#include "scene/scene.hpp"
#include "world/world.hpp"

namespace parode {

struct Frame {
    long step = 0;
    double time = 0;
    double kinetic = 0, potential = 0;
    Vec3 momentum{0, 0, 0}, angular_momentum{0, 0, 0};
    double com_height = 0, max_penetration = 0, mean_penetration = 0;
    double contacts = 0, disabled = 0;
    std::vector<double> positions;  // x, y, z per body, in id order
    double energy() const { return kinetic + potential; }
    Vec3 position(std::size_t body) const { return {positions[3 * body], positions[3 * body + 1], positions[3 * body + 2]}; }
};
constexpr int kFrameHeader = 16;  // doubles before the positions

struct Trajectory {
    nlohmann::json meta;             // scene, dt, solver, seed, ...
    std::vector<char> catom;         // per body: 1 if part of the catom ensemble
    double catom_radius = 0;         // largest catom radius (0: no catoms)
    std::vector<Frame> frames;
    std::size_t body_count() const { return catom.size(); }
    double dt() const { return meta.value("dt", 0.0); }
};

// An empty trajectory of a scene (metadata and catom mask).
Trajectory make_trajectory(const Scene& scene);
// Collective: the frame of the current state; positions (in gid order) only
// on the root process, which is the one that writes trajectories.
Frame capture_frame(const World& world, const Diagnostics& d, long step, double time, const Collectives& domain);

// Both throw std::runtime_error naming the file.
void write_trajectory(const std::string& path, const Trajectory& t);
Trajectory read_trajectory(const std::string& path);
bool is_trajectory_file(const std::string& path);

}  // namespace parode
