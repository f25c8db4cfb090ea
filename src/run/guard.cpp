// Run guard (see guard.hpp).
#include "run/guard.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "run/pipeline.hpp"

namespace parode {
namespace {

double speed(dBodyID b) {
    const dReal* v = dBodyGetLinearVel(b);
    return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

double gravity_norm(const Scene& sc) {
    return std::sqrt(sc.gravity[0] * sc.gravity[0] + sc.gravity[1] * sc.gravity[1] + sc.gravity[2] * sc.gravity[2]);
}

// Potential energy above the lowest body, plus lifting every body by 1 m.
double potential_headroom(const World& world) {
    const double g = gravity_norm(world.scene());
    double low = 1e300, mass = 0, mz = 0;
    for (std::size_t i = 0; i < world.body_count(); ++i) low = std::min(low, dBodyGetPosition(world.body(i))[2]);
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        dMass dm;
        dBodyGetMass(world.body(i), &dm);
        const double m = dm.mass;
        mass += m;
        mz += m * (dBodyGetPosition(world.body(i))[2] - low);
    }
    return g * (mz + mass * 1.0);
}

// Softened-Coulomb energy of every pole at distance 0 from an opposite pole.
double magnet_binding(const Scene& sc) {
    if (!sc.any_magnets()) return 0;
    double per_catom = 0;
    for (double q : sc.magnets.charges) per_catom += 0.5 * sc.magnets.strength * q * q / sc.magnets.softening;
    return static_cast<double>(sc.magnet_count()) * per_catom;
}

double motor_power(const ControllerSpec& c) {
    if (!c.enabled) return 0;
    const double wheel = std::max(std::fabs(c.speed_min), std::fabs(c.speed_max));
    const double steer = c.steer_gain * 2 * c.steer_amplitude;
    return 2.0 * (c.drive_joints.size() * c.drive_fmax * wheel + c.steer_joints.size() * c.steer_fmax * steer);
}

}  // namespace

std::string fastest_bodies(const World& world, std::size_t limit) {
    std::vector<std::pair<double, std::size_t>> v;
    for (std::size_t i = 0; i < world.body_count(); ++i) v.emplace_back(speed(world.body(i)), i);
    limit = std::min(limit, v.size());
    std::partial_sort(v.begin(), v.begin() + static_cast<long>(limit), v.end(),
                      [](const auto& a, const auto& b) { return a.first > b.first || (a.first == b.first && a.second < b.second); });
    std::ostringstream os;
    for (std::size_t k = 0; k < limit; ++k) os << (k ? ", " : "") << v[k].second << " (" << v[k].first << " m/s)";
    return os.str();
}

Guard::Guard(const World& world, const Diagnostics& initial, std::string dump_path)
    : scene_(world.scene()), initial_energy_(initial.energy()), dump_path_(std::move(dump_path)) {
    const GuardSpec& g = scene_.guard;
    if (g.max_energy_gain) {
        base_bound_ = *g.max_energy_gain;
    } else {
        base_bound_ = initial.kinetic + potential_headroom(world) + magnet_binding(scene_);
        motor_power_ = motor_power(scene_.controller);
    }
    remember(world, 0);
}

double Guard::energy_bound(double time) const { return base_bound_ + motor_power_ * time; }

nlohmann::json Guard::describe() const {
    return {{"finite_check", "every step"},
            {"energy_check", scene_.guard.energy ? "every observed step" : "off"},
            {"energy_bound_j", base_bound_}, {"motor_power_w", motor_power_},
            {"max_speed", scene_.guard.max_speed}, {"dump", dump_path_}};
}

void Guard::check_step(const World& world, long step) const {
    const std::vector<std::size_t> bad = nan_bodies(world, 10);
    if (!bad.empty()) {
        std::ostringstream os;
        os << nan_bodies(world, world.body_count()).size() << " bodies have a non-finite state (first ids:";
        for (std::size_t id : bad) os << ' ' << id;
        os << ")";
        fail(world, step, os.str());
    }
    const double vmax = scene_.guard.max_speed;
    if (vmax <= 0) return;
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (speed(world.body(i)) <= vmax) continue;
        std::ostringstream os;
        os << "body " << i << " moves faster than guard.max_speed = " << vmax << " m/s (fastest: "
           << fastest_bodies(world, 5) << ")";
        fail(world, step, os.str());
    }
}

void Guard::check_observed(const World& world, const Diagnostics& d, long step) {
    const double gain = d.energy() - initial_energy_;
    const double bound = energy_bound(step * scene_.dt);
    if (scene_.guard.energy && gain > bound) {
        std::ostringstream os;
        os << "runaway energy: total energy " << d.energy() << " J is " << gain << " J above the initial "
           << initial_energy_ << " J, past the bound of " << bound << " J (fastest bodies: " << fastest_bodies(world, 5)
           << ")";
        fail(world, step, os.str());
    }
    remember(world, step);
}

void Guard::remember(const World& world, long step) {
    if (dump_path_.empty()) return;
    good_.step = step;
    good_.data.resize(13 * world.body_count());
    double* out = good_.data.data();
    for (dBodyID b : world.bodies()) {
        const dReal* arrays[4] = {dBodyGetPosition(b), dBodyGetQuaternion(b), dBodyGetLinearVel(b), dBodyGetAngularVel(b)};
        const int sizes[4] = {3, 4, 3, 3};
        for (int a = 0; a < 4; ++a) for (int i = 0; i < sizes[a]; ++i) *out++ = arrays[a][i];
    }
}

std::string Guard::dump() const {
    std::ofstream out(dump_path_);
    out << "# parode last good state: scene " << scene_.name << ", step " << good_.step << ", time "
        << good_.step * scene_.dt << " s\nbody,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz\n";
    char buf[32];
    for (std::size_t i = 0; i < good_.data.size() / 13; ++i) {
        out << i;
        for (int k = 0; k < 13; ++k) {
            std::snprintf(buf, sizeof buf, ",%.17g", good_.data[13 * i + k]);
            out << buf;
        }
        out << '\n';
    }
    if (!out) return "; the last good state could not be written to " + dump_path_;
    return "; last good state (step " + std::to_string(good_.step) + ") written to " + dump_path_;
}

void Guard::fail(const World&, long step, const std::string& what) const {
    std::ostringstream os;
    os << "step " << step << " (t = " << step * scene_.dt << " s): " << what << "; stopping";
    if (!dump_path_.empty()) os << dump();
    throw SimulationError(os.str());
}

}  // namespace parode
