// Error metrics against a reference trajectory (see error_metrics.hpp).
#include "io/error_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace parode {
namespace {

double norm(const Vec3& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

Vec3 diff(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

Vec3 centroid(const Frame& f, const std::vector<char>& sel) {
    Vec3 c{0, 0, 0};
    double n = 0;
    for (std::size_t i = 0; i < sel.size(); ++i) {
        if (!sel[i]) continue;
        for (int k = 0; k < 3; ++k) c[k] += f.positions[3 * i + k];
        n += 1;
    }
    if (n > 0) for (double& x : c) x /= n;
    return c;
}

double horizontal_spread(const Frame& f, const std::vector<char>& sel) {
    const Vec3 c = centroid(f, sel);
    double sum = 0, n = 0;
    for (std::size_t i = 0; i < sel.size(); ++i) {
        if (!sel[i]) continue;
        const Vec3 d = diff(f.position(i), c);
        sum += d[0] * d[0] + d[1] * d[1];
        n += 1;
    }
    return n > 0 ? std::sqrt(sum / n) : 0.0;
}

double escaped_count(const Frame& first, const Frame& f, const std::vector<char>& sel, double margin) {
    double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
    for (std::size_t i = 0; i < sel.size(); ++i) {
        if (!sel[i]) continue;
        for (int k = 0; k < 2; ++k) {
            lo[k] = std::min(lo[k], first.positions[3 * i + k] - margin);
            hi[k] = std::max(hi[k], first.positions[3 * i + k] + margin);
        }
    }
    double out = 0;
    for (std::size_t i = 0; i < sel.size(); ++i) {
        if (!sel[i]) continue;
        const double x = f.positions[3 * i], y = f.positions[3 * i + 1];
        out += (x < lo[0] || x > hi[0] || y < lo[1] || y > hi[1]) ? 1 : 0;
    }
    return out;
}

nlohmann::json position_error_json(const Frame& a, const Frame& b) {
    const PositionError e = position_error(a, b);
    return {{"step", a.step}, {"time", a.time}, {"rms", e.rms}, {"max", e.max}};
}

nlohmann::json horizons_json(const Trajectory& run, const Trajectory& ref,
                             const std::vector<std::pair<std::size_t, std::size_t>>& m, const std::vector<long>& ks) {
    nlohmann::json out = nlohmann::json::array();
    for (long k : ks) {
        auto it = std::find_if(m.begin(), m.end(), [&](const auto& p) { return run.frames[p.first].step >= k; });
        if (it == m.end()) continue;
        nlohmann::json e = position_error_json(run.frames[it->first], ref.frames[it->second]);
        e["horizon_steps"] = k;
        out.push_back(e);
    }
    return out;
}

// Position error at every matched frame: {time, rms, max} arrays.
nlohmann::json series_json(const Trajectory& run, const Trajectory& ref,
                           const std::vector<std::pair<std::size_t, std::size_t>>& m) {
    nlohmann::json t = nlohmann::json::array(), rms = nlohmann::json::array(), mx = nlohmann::json::array();
    for (const auto& p : m) {
        const PositionError e = position_error(run.frames[p.first], ref.frames[p.second]);
        t.push_back(run.frames[p.first].time);
        rms.push_back(e.rms);
        mx.push_back(e.max);
    }
    return {{"time", t}, {"rms", rms}, {"max", mx}};
}

double max_energy_gain(const Trajectory& t) {
    double gain = -1e300;
    for (const Frame& f : t.frames) gain = std::max(gain, f.energy() - t.frames.front().energy());
    return gain;
}

nlohmann::json energy_json(const Trajectory& run, const Trajectory& ref,
                           const std::vector<std::pair<std::size_t, std::size_t>>& m) {
    double max_abs = 0;
    for (const auto& p : m) max_abs = std::max(max_abs, std::fabs(run.frames[p.first].energy() - ref.frames[p.second].energy()));
    const Frame& a = run.frames[m.back().first];
    const Frame& b = ref.frames[m.back().second];
    return {{"initial", run.frames.front().energy()}, {"final", a.energy()},
            {"drift", a.energy() - run.frames.front().energy()}, {"max_gain", max_energy_gain(run)},
            {"reference_drift", b.energy() - ref.frames.front().energy()}, {"reference_max_gain", max_energy_gain(ref)},
            {"final_diff", a.energy() - b.energy()}, {"max_abs_diff", max_abs}};
}

nlohmann::json momentum_json(const Trajectory& run, const Trajectory& ref,
                             const std::vector<std::pair<std::size_t, std::size_t>>& m) {
    const Frame& a = run.frames[m.back().first];
    const Frame& b = ref.frames[m.back().second];
    return {{"linear_drift", norm(diff(a.momentum, run.frames.front().momentum))},
            {"angular_drift", norm(diff(a.angular_momentum, run.frames.front().angular_momentum))},
            {"reference_linear_drift", norm(diff(b.momentum, ref.frames.front().momentum))},
            {"reference_angular_drift", norm(diff(b.angular_momentum, ref.frames.front().angular_momentum))},
            {"linear_diff", norm(diff(a.momentum, b.momentum))}};
}

nlohmann::json observable_json(double run, double ref) {
    return {{"run", run}, {"reference", ref}, {"diff", run - ref}};
}

nlohmann::json observables_json(const Trajectory& run, const Trajectory& ref, const Frame& a, const Frame& b) {
    const PileObservables x = observables(run, a), y = observables(ref, b);
    return {{"time", a.time},
            {"com_height", observable_json(x.com_height, y.com_height)},
            {"spread", observable_json(x.spread, y.spread)},
            {"escaped", observable_json(x.escaped, y.escaped)},
            {"shape_drift", observable_json(x.shape_drift, y.shape_drift)},
            {"shape_error", shape_error(a, b, selection(run))}};
}

nlohmann::json penetration_json(const Trajectory& run, const Trajectory& ref) {
    auto stats = [](const Trajectory& t, double& max, double& mean) {
        double sum = 0, n = 0;
        for (const Frame& f : t.frames) {
            max = std::max(max, f.max_penetration);
            sum += f.mean_penetration * f.contacts;
            n += f.contacts;
        }
        mean = n > 0 ? sum / n : 0.0;
    };
    double a_max = 0, a_mean = 0, b_max = 0, b_mean = 0;
    stats(run, a_max, a_mean);
    stats(ref, b_max, b_mean);
    return {{"max", a_max}, {"mean", a_mean}, {"reference_max", b_max}, {"reference_mean", b_mean}};
}

}  // namespace

std::vector<char> selection(const Trajectory& t) {
    const bool any = std::any_of(t.catom.begin(), t.catom.end(), [](char c) { return c != 0; });
    return any ? t.catom : std::vector<char>(t.catom.size(), 1);
}

PositionError position_error(const Frame& a, const Frame& b) {
    PositionError e;
    const std::size_t n = a.positions.size() / 3;
    for (std::size_t i = 0; i < n; ++i) {
        const double d = norm(diff(a.position(i), b.position(i)));
        e.rms += d * d;
        e.max = std::max(e.max, d);
    }
    e.rms = n ? std::sqrt(e.rms / static_cast<double>(n)) : 0.0;
    return e;
}

double shape_error(const Frame& a, const Frame& b, const std::vector<char>& sel) {
    const Vec3 ca = centroid(a, sel), cb = centroid(b, sel);
    double sum = 0, n = 0;
    for (std::size_t i = 0; i < sel.size(); ++i) {
        if (!sel[i]) continue;
        const double d = norm(diff(diff(a.position(i), ca), diff(b.position(i), cb)));
        sum += d * d;
        n += 1;
    }
    return n > 0 ? std::sqrt(sum / n) : 0.0;
}

PileObservables observables(const Trajectory& t, const Frame& f) {
    const std::vector<char> sel = selection(t);
    PileObservables o;
    o.com_height = f.com_height;
    o.spread = horizontal_spread(f, sel);
    o.escaped = escaped_count(t.frames.front(), f, sel, t.catom_radius);
    o.shape_drift = shape_error(f, t.frames.front(), sel);
    return o;
}

std::vector<std::pair<std::size_t, std::size_t>> match_frames(const Trajectory& run, const Trajectory& ref) {
    const double tol = 1e-6 * std::min(run.dt() > 0 ? run.dt() : 1.0, ref.dt() > 0 ? ref.dt() : 1.0);
    std::vector<std::pair<std::size_t, std::size_t>> out;
    std::size_t j = 0;
    for (std::size_t i = 0; i < run.frames.size(); ++i) {
        const double t = run.frames[i].time;
        while (j < ref.frames.size() && ref.frames[j].time < t - tol) ++j;
        if (j == ref.frames.size()) break;
        if (std::fabs(ref.frames[j].time - t) <= tol) out.emplace_back(i, j);
    }
    return out;
}

nlohmann::json compare_trajectories(const Trajectory& run, const Trajectory& ref, const std::vector<long>& horizons) {
    if (run.body_count() != ref.body_count()) {
        throw std::runtime_error("the reference has " + std::to_string(ref.body_count()) + " bodies, the run " +
                                 std::to_string(run.body_count()) + ": not the same scene");
    }
    const auto m = match_frames(run, ref);
    if (m.empty()) throw std::runtime_error("the run and the reference share no frame of equal simulated time");
    const Frame& a = run.frames[m.back().first];
    const Frame& b = ref.frames[m.back().second];
    nlohmann::json e;
    e["reference"] = ref.meta;
    e["reference"].erase("catom_mask");
    e["matched_frames"] = m.size();
    e["trajectory"] = horizons_json(run, ref, m, horizons);
    e["final"] = position_error_json(a, b);
    e["series"] = series_json(run, ref, m);
    e["penetration"] = penetration_json(run, ref);
    e["energy"] = energy_json(run, ref, m);
    e["momentum"] = momentum_json(run, ref, m);
    e["observables"] = observables_json(run, ref, a, b);
    return e;
}

}  // namespace parode
