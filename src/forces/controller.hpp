// The deterministic buggy driver: steering follows a smoothed square wave (left
// circle, right circle: a figure eight per period) and the drive speed a slow
// sine between speed_min and speed_max. It depends only on time and joint
// angles, so every run drives the same way.
// Trade-off: a fixed script, not a path follower; enough to exercise motors,
// steering and contacts the same way in every configuration.
#pragma once
#include "world/world.hpp"

namespace parode {

struct DriveCommand {
    double steer;  // target steering angle (rad)
    double speed;  // wheel angular velocity (rad/s)
};

DriveCommand drive_command(const ControllerSpec& c, double t);
void apply_controller(World& world, const ControllerSpec& c, double t);

}  // namespace parode
