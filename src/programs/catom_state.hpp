// One catom's program state inside the catom programs' pass (private to
// src/programs/): its program object, mail, values, magnets and timer; and
// a catom's radius.
// Trade-off: a plain struct shared by the pass and its state exchange
// instead of accessors: both are the pass.
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "programs/program_pass.hpp"

namespace parode {

struct ProgramPass::Catom {
    std::unique_ptr<CatomProgram> program;
    std::vector<CatomMessage> inbox;                             // to deliver this step
    std::vector<std::pair<std::uint32_t, CatomMessage>> outbox;  // sent this step: (to, message)
    std::array<double, kProgramValues> values{};
    bool magnets = true, started = false;
    std::uint8_t poles_off = 0;  // poles switched off one by one (bit p: pole p)
    double timer_at = -1;  // negative: no timer
    std::uint32_t events = 0;
    std::string error;     // this step's first failure
};

// The radius of catom `gid` (a [[bodies]] catom's own, else the prototype's).
inline double catom_radius(const Scene& scene, std::uint32_t gid) {
    return gid < scene.bodies.size() ? scene.bodies[gid].shape.radius : scene.catoms.proto.shape.radius;
}

}  // namespace parode
