// The deterministic buggy driver: the chassis follows a fixed track from its
// start pose, on a schedule. The track is a figure eight of two circles of
// radius R (a left circle, anticlockwise seen from above, then a right one;
// the heading goes +2 pi then back by -2 pi, 4 pi R of track per eight) or a
// straight line. The schedule drives along it at a wheel speed that varies
// slowly (a sine between speed_min and speed_max), so the target point and
// heading at time t are known in closed form. Steering: feedforward for the
// track's curvature plus a proportional law on the chassis yaw against the
// track heading, corrected towards the track by the cross-track error; the
// wheels speed up by the along-track lag (never above 1.25 x speed_max).
// Trade-off: tracking a scheduled point, not the distance actually driven,
// keeps the driver stateless (every run and configuration drives the same
// script) and brings the buggy back to its start after every eight whatever
// wheel slip and the ramp do; the speed is the schedule's plus a small
// catch-up term, not exactly the sine.
#pragma once
#include "forces/force_pass.hpp"
#include "world/world.hpp"

namespace parode {

struct TrackPoint {
    double x, y;       // target position of the chassis (m)
    double heading;    // track direction (rad, anticlockwise from +x, unwrapped)
    double curvature;  // signed curvature (1/m, left positive)
};

// Track length the schedule covers in t seconds (m).
double drive_distance(const ControllerSpec& c, double t);
// Time at which the schedule has covered `distance` metres of track (s).
double time_at_distance(const ControllerSpec& c, double distance);
// Track length of one figure eight (m): two circles of c.radius.
double eight_length(const ControllerSpec& c);
// Target pose `distance` metres along the track.
TrackPoint track_point(const ControllerSpec& c, double distance);
void apply_controller(World& world, const ControllerSpec& c, double t);

// The "controller" force pass: apply_controller with the scene's [controller].
class ControllerPass final : public ForcePass {
public:
    explicit ControllerPass(const Scene& scene) : spec_(scene.controller) {}
    std::string name() const override { return "controller"; }
    void apply(World& world, double time) override { apply_controller(world, spec_, time); }

private:
    const ControllerSpec& spec_;
};

}  // namespace parode
