// Buggy driver (see controller.hpp): schedule, track, steering and wheel laws.
#include "forces/controller.hpp"

#include <algorithm>
#include <cmath>

namespace parode {

namespace {

constexpr double kTwoPi = 6.283185307179586;

double scheduled_speed(const ControllerSpec& c, double t) {  // wheel rad/s
    const double mid = 0.5 * (c.speed_min + c.speed_max), amp = 0.5 * (c.speed_max - c.speed_min);
    return mid + amp * std::sin(kTwoPi * t / c.speed_period);
}

// Pose on the track in the start frame (start at the origin, heading +x).
TrackPoint local_point(const ControllerSpec& c, double s) {
    if (c.path == DrivePath::Straight) return {s, 0.0, 0.0, 0.0};
    const double r = c.radius, circle = 0.5 * eight_length(c);
    s = std::fmod(s, eight_length(c));
    const double side = s < circle ? 1.0 : -1.0;  // left circle first, then the right one
    const double a = (s < circle ? s : s - circle) / r;
    return {r * std::sin(a), side * r * (1 - std::cos(a)), side * a, side / r};
}

struct Pose {
    double x, y, yaw;
};

Pose chassis_pose(dBodyID body) {
    const dReal* p = dBodyGetPosition(body);
    const dReal* R = dBodyGetRotation(body);
    return {p[0], p[1], std::atan2(R[4], R[0])};
}

// Steering angle (rad, left positive) towards the track point, and the lag along it (m).
std::pair<double, double> steer_and_lag(const ControllerSpec& c, const TrackPoint& p, const Pose& now) {
    const double dx = p.x - now.x, dy = p.y - now.y;
    const double lag = dx * std::cos(p.heading) + dy * std::sin(p.heading);
    const double left = -dx * std::sin(p.heading) + dy * std::cos(p.heading);  // track is to the left
    const double heading = p.heading + std::atan(c.track_gain * left);
    const double error = std::remainder(heading - now.yaw, kTwoPi);
    const double angle = std::atan(c.wheelbase * p.curvature) + c.heading_gain * error;
    return {std::clamp(angle, -c.steer_amplitude, c.steer_amplitude), lag};
}

}  // namespace

double drive_distance(const ControllerSpec& c, double t) {
    const double mid = 0.5 * (c.speed_min + c.speed_max), amp = 0.5 * (c.speed_max - c.speed_min);
    const double turns = mid * t + amp * c.speed_period / kTwoPi * (1 - std::cos(kTwoPi * t / c.speed_period));
    return c.wheel_radius * turns;
}

double time_at_distance(const ControllerSpec& c, double distance) {
    double lo = 0, hi = 1;
    while (drive_distance(c, hi) < distance && hi < 1e9) hi *= 2;
    for (int i = 0; i < 100; ++i) {
        const double mid = 0.5 * (lo + hi);
        (drive_distance(c, mid) < distance ? lo : hi) = mid;
    }
    return hi;
}

double eight_length(const ControllerSpec& c) { return 2 * kTwoPi * c.radius; }

TrackPoint track_point(const ControllerSpec& c, double distance) {
    const TrackPoint l = local_point(c, distance);
    const double cs = std::cos(c.start_heading), sn = std::sin(c.start_heading);
    return {c.start[0] + cs * l.x - sn * l.y, c.start[1] + sn * l.x + cs * l.y, c.start_heading + l.heading,
            l.curvature};
}

void apply_controller(World& world, const ControllerSpec& c, double t) {
    const TrackPoint target = track_point(c, drive_distance(c, t));
    const auto [steer, lag] = steer_and_lag(c, target, chassis_pose(world.body(world.local_of(static_cast<std::uint32_t>(c.chassis)))));
    const double speed = std::clamp(scheduled_speed(c, t) + c.pace_gain * lag / c.wheel_radius, 0.0, 1.25 * c.speed_max);
    for (int j : c.steer_joints) {
        dJointID id = world.joint(static_cast<std::size_t>(j));
        // ODE's hinge-2 angle 1 grows clockwise about an upward axis 1: a left turn is negative.
        const double err = -steer - dJointGetHinge2Angle1(id);
        dJointSetHinge2Param(id, dParamVel, c.steer_gain * err);
        dJointSetHinge2Param(id, dParamFMax, c.steer_fmax);
    }
    for (int j : c.drive_joints) {
        dJointID id = world.joint(static_cast<std::size_t>(j));
        dJointSetHinge2Param(id, dParamVel2, -speed);  // forward is -axis2 here
        dJointSetHinge2Param(id, dParamFMax2, c.drive_fmax);
    }
}

}  // namespace parode
