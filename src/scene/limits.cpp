// Scene-wide magnitude checks (see limits.hpp for the bounds and why).
// Trade-off: these run after the bodies exist (one pass over them), because a
// mass ratio or a prism's extent is not a property of any single key.
#include "scene/limits.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "util/text.hpp"

namespace parode::limits {
namespace {

// The table that declared body `i`: its [[bodies]] entry or the [catoms] table.
Node body_table(const Node& root, std::size_t i, std::size_t hand_written) {
    return i < hand_written ? root.at("bodies").index(i) : root.at("catoms");
}

std::string body_label(const Scene& sc, std::size_t i, std::size_t hand_written) {
    if (i >= hand_written) return "the catoms";
    return "bodies[" + std::to_string(i) + "] '" + sc.bodies[i].name + "'";
}

}  // namespace

std::string coordinate_text() {
    return "an array of 3 numbers, each in [-" + short_number(kMaxCoordinate) + ", " + short_number(kMaxCoordinate) + "] (m)";
}

std::string speed_text(double dt) {
    return "an array of 3 numbers of length <= " + short_number(max_speed(dt)) + " (m/s: at most " + short_number(kMaxStepTravel) +
           " m per step of dt = " + short_number(dt) + " s)";
}

std::string turn_rate_text(double dt) {
    return "an array of 3 numbers of length <= " + short_number(max_turn_rate(dt)) + " (rad/s: at most one revolution per step of dt = " +
           short_number(dt) + " s)";
}

Range joint_param_range(const std::string& name) {
    std::string base = name;
    if (!base.empty() && (base.back() == '2' || base.back() == '3')) base.pop_back();
    if (base == "vel") return {-kMaxMotorSpeed, kMaxMotorSpeed};
    if (base == "fmax") return {0, Node::kInf};
    if (base == "lo_stop" || base == "hi_stop") return {-Node::kInf, Node::kInf};
    return {0, 1};  // erp, stop_erp, suspension_erp, cfm, stop_cfm, suspension_cfm, bounce, fudge_factor
}

void check_mass_ratio(const Node& root, const Scene& sc, std::size_t hand_written) {
    if (sc.body_count() == 0) return;
    // Body i of the hand-written ones, or the catoms' prototype at index hand_written.
    auto mass = [&sc, hand_written](std::size_t i) { return i < hand_written ? sc.bodies[i].mass : sc.catoms.proto.mass; };
    const std::size_t n = hand_written + (sc.catoms.count ? 1 : 0);
    std::size_t light = 0, heavy = 0;
    for (std::size_t i = 1; i < n; ++i) {
        if (mass(i) < mass(light)) light = i;
        if (mass(i) > mass(heavy)) heavy = i;
    }
    const double lo = mass(light), hi = mass(heavy);
    if (hi <= kMaxMassRatio * lo) return;
    body_table(root, heavy, hand_written)
        .fail_value("mass", "a mass at most " + short_number(kMaxMassRatio) + " times the lightest body's (" +
                                body_label(sc, light, hand_written) + ", " + short_number(lo) + " kg)",
                    short_number(hi));
}

// The prism's corners bound every catom (plus the jitter).
void check_catom_extent(const Node& root, const Scene& sc, std::size_t /*hand_written*/) {
    const CatomBlock& c = sc.catoms;
    if (c.count == 0) return;
    double reach = 0;
    for (int a = 0; a < 3; ++a) {
        const double half = a < 2 ? 0.5 * static_cast<double>(c.dims[a] - 1) * c.spacing : 0.0;
        const double lo = a < 2 ? c.base[static_cast<std::size_t>(a)] - half : c.base[2] + c.proto.shape.radius;
        const double hi = a < 2 ? c.base[static_cast<std::size_t>(a)] + half
                                : c.base[2] + c.proto.shape.radius + static_cast<double>(c.dims[2] - 1) * c.spacing;
        reach = std::max({reach, std::fabs(lo) + c.jitter, std::fabs(hi) + c.jitter});
    }
    if (reach <= kMaxCoordinate) return;
    root.at("catoms").fail_value("spacing",
                                 "a prism inside the coordinate bound (|x|, |y|, |z| <= " + short_number(kMaxCoordinate) +
                                     " m)",
                                 "a prism of " + std::to_string(c.count) + " catoms that reaches " + short_number(reach) + " m");
}

}  // namespace parode::limits
