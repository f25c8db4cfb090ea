// Pass criteria (see checks.hpp).
#include "run/checks.hpp"

#include <algorithm>
#include <cmath>

#include "domain/gather.hpp"
#include "io/error_metrics.hpp"

namespace parode {
namespace {

nlohmann::json item(const std::string& name, double value, double bound, bool passed) {
    return {{"name", name}, {"value", value}, {"bound", bound}, {"passed", passed}};
}

double max_displacement(const Trajectory& start, const Frame& now) {
    const std::vector<char> sel = selection(start);
    double out = 0;
    for (std::size_t i = 0; i < sel.size(); ++i) {
        if (!sel[i]) continue;
        const Vec3 a = start.frames.front().position(i), b = now.position(i);
        out = std::max(out, std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                                      (a[2] - b[2]) * (a[2] - b[2])));
    }
    return out;
}

// Collective: the largest speed of any body.
double max_speed(const World& world, const Collectives& domain) {
    double out = 0;
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (world.ghost(i)) continue;
        const dReal* v = dBodyGetLinearVel(world.body(i));
        out = std::max(out, std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]));
    }
    return domain.max(out);
}

// Collective: positions in gid order on the root (of `only`, when given).
std::vector<double> positions(const World& world, const Collectives& domain, const std::vector<std::uint32_t>* only = nullptr) {
    return gather_rows(domain, world, 3, [&world](std::size_t i, double* out) {
        const dReal* x = dBodyGetPosition(world.body(i));
        for (int c = 0; c < 3; ++c) out[c] = x[c];
    }, only);
}

void position_items(const Scene& sc, const Frame& now, const std::vector<Vec3>& extremes, nlohmann::json& items) {
    static const char* axes = "xyz";
    for (std::size_t k = 0; k < sc.checks.positions.size(); ++k) {
        const PositionCheck& c = sc.checks.positions[k];
        const double x = now.position(static_cast<std::size_t>(c.body))[c.axis];
        const double lo = c.always ? std::min(x, extremes[k][0]) : x, hi = c.always ? std::max(x, extremes[k][1]) : x;
        const std::string given = sc.body(static_cast<std::size_t>(c.body)).name;
        const std::string body = given.empty() ? std::to_string(c.body) : given;
        const std::string name = "position " + body + "." + axes[c.axis] + (c.always ? " always" : "");
        if (c.min > -1e300) items.push_back(item(name + " >= min", lo, c.min, lo >= c.min));
        if (c.max < 1e300) items.push_back(item(name + " <= max", hi, c.max, hi <= c.max));
    }
}

}  // namespace

// The start frame holds every body's initial position (its origin, which a
// restarted run carries over), so displacement and footprint refer to step 0.
Checker::Checker(const World& world, const Diagnostics& initial, const Collectives& domain)
    : scene_(world.scene()), domain_(domain), start_(make_trajectory(world.scene())), initial_energy_(initial.energy()) {
    Frame f = capture_frame(world, initial, 0, 0.0, domain);
    f.positions = gather_rows(domain, world, 3, [&world](std::size_t i, double* out) {
        for (int c = 0; c < 3; ++c) out[c] = world.origin(i)[static_cast<std::size_t>(c)];
    });
    for (const PositionCheck& c : scene_.checks.positions) {
        checked_.push_back(static_cast<std::uint32_t>(c.body));
        const double x = domain.root() ? f.position(static_cast<std::size_t>(c.body))[c.axis] : 0.0;
        extremes_.push_back({x, x, 0});
    }
    std::sort(checked_.begin(), checked_.end());
    checked_.erase(std::unique(checked_.begin(), checked_.end()), checked_.end());
    start_.frames.push_back(std::move(f));
}

nlohmann::json Checker::state() const {
    return {{"initial_energy", initial_energy_}, {"max_penetration", max_penetration_},
            {"max_energy_gain", max_energy_gain_}, {"extremes", extremes_}};
}

void Checker::restore(const nlohmann::json& s) {
    initial_energy_ = s.at("initial_energy").get<double>();
    max_penetration_ = s.at("max_penetration").get<double>();
    max_energy_gain_ = s.at("max_energy_gain").get<double>();
    const auto ex = s.at("extremes").get<std::vector<Vec3>>();
    if (ex.size() == extremes_.size()) extremes_ = ex;
}

void Checker::observe(const World& world, const Diagnostics& d) {
    max_penetration_ = std::max(max_penetration_, d.max_penetration);
    max_energy_gain_ = std::max(max_energy_gain_, d.energy() - initial_energy_);
    if (extremes_.empty()) return;
    const std::vector<double> x = positions(world, domain_, &checked_);
    if (!domain_.root()) return;
    for (std::size_t k = 0; k < extremes_.size(); ++k) {
        const PositionCheck& c = scene_.checks.positions[k];
        const double v = x[3 * static_cast<std::size_t>(c.body) + static_cast<std::size_t>(c.axis)];
        extremes_[k][0] = std::min(extremes_[k][0], v);
        extremes_[k][1] = std::max(extremes_[k][1], v);
    }
}

nlohmann::json Checker::result(const World& world, const Diagnostics& last) const {
    const CheckSpec& c = scene_.checks;
    const Frame now = capture_frame(world, last, 0, 0.0, domain_);
    const double vmax = max_speed(world, domain_);
    if (!domain_.root()) return nlohmann::json::parse(from_root(domain_, ""));
    nlohmann::json items = nlohmann::json::array();
    if (c.max_penetration) items.push_back(item("max_penetration", max_penetration_, *c.max_penetration, max_penetration_ <= *c.max_penetration));
    if (c.max_final_penetration) {
        const double d = last.max_penetration;
        items.push_back(item("max_final_penetration", d, *c.max_final_penetration, d <= *c.max_final_penetration));
    }
    if (c.max_energy_gain) items.push_back(item("max_energy_gain", max_energy_gain_, *c.max_energy_gain, max_energy_gain_ <= *c.max_energy_gain));
    if (c.max_displacement) {
        const double d = max_displacement(start_, now);
        items.push_back(item("max_displacement", d, *c.max_displacement, d <= *c.max_displacement));
    }
    if (c.max_final_speed) {
        const double v = vmax;
        items.push_back(item("max_final_speed", v, *c.max_final_speed, v <= *c.max_final_speed));
    }
    if (c.min_disabled) {
        const double f = static_cast<double>(last.disabled) / static_cast<double>(world.global_body_count());
        items.push_back(item("min_disabled", f, *c.min_disabled, f >= *c.min_disabled));
    }
    if (c.max_escaped) {
        const double n = observables(start_, now).escaped;
        items.push_back(item("max_escaped", n, static_cast<double>(*c.max_escaped), n <= static_cast<double>(*c.max_escaped)));
    }
    position_items(scene_, now, extremes_, items);
    bool passed = true;
    for (const auto& i : items) passed = passed && i["passed"].get<bool>();
    const nlohmann::json verdict = {{"passed", passed}, {"items", items}};
    from_root(domain_, verdict.dump());
    return verdict;
}

}  // namespace parode
