// Buggy driver (see controller.hpp).
#include "forces/controller.hpp"

#include <cmath>

namespace parode {

DriveCommand drive_command(const ControllerSpec& c, double t) {
    const double two_pi = 6.283185307179586;
    const double steer = c.steer_amplitude * std::tanh(3 * std::sin(two_pi * t / c.period));
    const double mid = 0.5 * (c.speed_min + c.speed_max);
    const double amp = 0.5 * (c.speed_max - c.speed_min);
    return {steer, mid + amp * std::sin(two_pi * t / c.speed_period)};
}

void apply_controller(World& world, const ControllerSpec& c, double t) {
    const DriveCommand cmd = drive_command(c, t);
    for (int j : c.steer_joints) {
        dJointID id = world.joint(static_cast<std::size_t>(j));
        const double err = cmd.steer - dJointGetHinge2Angle1(id);
        dJointSetHinge2Param(id, dParamVel, c.steer_gain * err);
        dJointSetHinge2Param(id, dParamFMax, c.steer_fmax);
    }
    for (int j : c.drive_joints) {
        dJointID id = world.joint(static_cast<std::size_t>(j));
        dJointSetHinge2Param(id, dParamVel2, -cmd.speed);  // forward is -axis2 here
        dJointSetHinge2Param(id, dParamFMax2, c.drive_fmax);
    }
}

}  // namespace parode
