// [guard] and [checks] readers (see scene_checks.hpp).
#include "scene/scene_checks.hpp"

#include "scene/scene_keys.hpp"

namespace parode {
namespace {

std::optional<double> opt_number(const Node& t, const std::string& key, double lo) {
    if (!t.has(key)) return std::nullopt;
    return t.number_required(key, lo);
}

int checked_body(const Scene& sc, const Node& t) {
    const toml::value& v = t.at("body").value();
    if (v.is_string()) {
        const int b = sc.find_body(v.as_string().str);
        if (b >= 0) return b;
    } else if (v.is_integer() && v.as_integer() >= 0 && v.as_integer() < static_cast<long>(sc.body_count())) {
        return static_cast<int>(v.as_integer());
    }
    t.fail("body", "the name of a [[bodies]] entry or a body id in [0, " + std::to_string(sc.body_count() - 1) + "]");
}

PositionCheck read_position_check(const Scene& sc, const Node& t) {
    t.expect_keys(table_keys("[[checks.position]]"));
    PositionCheck c;
    c.body = checked_body(sc, t);
    const std::string axis = t.choice("axis", "z", {"x", "y", "z"});
    c.axis = axis == "x" ? 0 : axis == "y" ? 1 : 2;
    if (!t.has("min") && !t.has("max")) t.fail_here("key '" + t.path() + "': expected 'min', 'max' or both");
    c.min = t.number("min", c.min);
    c.max = t.number("max", c.max);
    if (c.min > c.max) t.fail("max", "a number >= min");
    c.always = t.boolean("always", false);
    return c;
}

}  // namespace

void read_guard(const Node& root, GuardSpec& g) {
    if (!root.has("guard")) return;
    const Node t = root.at("guard");
    t.expect_keys(table_keys("guard"));
    g.energy = t.boolean("energy", g.energy);
    g.max_energy_gain = opt_number(t, "max_energy_gain", 0.0);
    g.max_speed = t.number("max_speed", g.max_speed, 1e-9, g.max_speed);  // at most the speed bound at this dt
}

void read_checks(const Node& root, Scene& sc) {
    if (!root.has("checks")) return;
    const Node t = root.at("checks");
    t.expect_keys(table_keys("checks"));
    CheckSpec& c = sc.checks;
    c.max_penetration = opt_number(t, "max_penetration", 0.0);
    c.max_final_penetration = opt_number(t, "max_final_penetration", 0.0);
    c.max_energy_gain = opt_number(t, "max_energy_gain", -Node::kInf);
    c.max_displacement = opt_number(t, "max_displacement", 0.0);
    c.max_final_speed = opt_number(t, "max_final_speed", 0.0);
    if (t.has("min_disabled")) c.min_disabled = t.number_required("min_disabled", 0.0, 1.0);
    if (t.has("max_escaped")) c.max_escaped = t.integer("max_escaped", 0, 0, 1000000000);
    if (!t.has("position")) return;
    const Node arr = t.at("position");
    for (std::size_t i = 0; i < arr.array_size(); ++i) c.positions.push_back(read_position_check(sc, arr.index(i)));
}

}  // namespace parode
