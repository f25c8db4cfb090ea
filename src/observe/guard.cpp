// Run guard (see guard.hpp).
#include "observe/guard.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "util/errors.hpp"
#include "exec/loops.hpp"

namespace parode {
namespace {

double speed(dBodyID b) {
    const dReal* v = dBodyGetLinearVel(b);
    return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

double gravity_norm(const Scene& sc) {
    return std::sqrt(sc.gravity[0] * sc.gravity[0] + sc.gravity[1] * sc.gravity[1] + sc.gravity[2] * sc.gravity[2]);
}

double height(const World& world, std::size_t i, const Vec3& up) {
    const dReal* x = dBodyGetPosition(world.body(i));
    return x[0] * up[0] + x[1] * up[1] + x[2] * up[2];
}

// Collective: potential energy above the lowest body, plus lifting every body by 1 m.
double potential_headroom(const World& world, const Collectives& domain) {
    const Vec3 up = up_direction(world.scene());
    double low = HUGE_VAL;
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (!world.ghost(i)) low = std::min(low, height(world, i, up));
    }
    low = domain.min(low);
    ExactSum sums[2];  // mass, mass * height above the lowest
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (world.ghost(i)) continue;
        const double mass = world.mass_of(world.gid(i)).mass;
        sums[0].add(mass);
        sums[1].add(mass * (height(world, i, up) - low));
    }
    domain.sum(sums, 2);
    return gravity_norm(world.scene()) * (sums[1].value() + sums[0].value() * 1.0);
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

// Collective: the first `limit` gids of all processes' non-finite bodies.
std::string first_nan_ids(const World& world, const Collectives& domain, std::size_t limit) {
    std::string mine;
    for (std::uint32_t id : nan_bodies(world, limit)) mine += std::to_string(id) + " ";
    std::istringstream all(domain.all_text(mine, " "));
    std::vector<std::uint32_t> ids;
    for (std::uint32_t id; all >> id;) ids.push_back(id);
    std::sort(ids.begin(), ids.end());
    ids.resize(std::min(limit, ids.size()));
    std::ostringstream os;
    for (std::uint32_t id : ids) os << ' ' << id;
    return os.str();
}

}  // namespace

std::string fastest_bodies(const World& world, const Collectives& domain, std::size_t limit, double above) {
    struct Entry {
        double speed;
        std::uint32_t gid;
    };
    std::vector<Entry> v;
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        const double s = speed(world.body(i));
        if (!world.ghost(i) && !(s <= above)) v.push_back({s, world.gid(i)});  // NaN speeds are listed
    }
    auto faster = [](const Entry& a, const Entry& b) { return a.speed > b.speed || (a.speed == b.speed && a.gid < b.gid); };
    const std::size_t k = std::min(limit, v.size());
    std::partial_sort(v.begin(), v.begin() + static_cast<long>(k), v.end(), faster);
    std::vector<char> mine(k * sizeof(Entry));
    if (k) std::memcpy(mine.data(), v.data(), mine.size());
    std::vector<Entry> all;
    for (const auto& part : domain.all_gather(mine)) {
        const std::size_t n = part.size() / sizeof(Entry);
        const std::size_t at = all.size();
        all.resize(at + n);
        if (n) std::memcpy(all.data() + at, part.data(), part.size());
    }
    std::sort(all.begin(), all.end(), faster);
    std::ostringstream os;
    for (std::size_t j = 0; j < std::min(limit, all.size()); ++j) {
        os << (j ? ", " : "") << all[j].gid << " (" << all[j].speed << " m/s)";
    }
    return os.str();
}

Guard::Guard(const World& world, const Diagnostics& initial, const Collectives& domain, const LoopRunner& loops,
             std::string dump_path)
    : scene_(world.scene()), domain_(domain), loops_(loops), initial_energy_(initial.energy()), dump_path_(std::move(dump_path)) {
    const GuardSpec& g = scene_.guard;
    const double headroom = potential_headroom(world, domain);  // collective: always computed
    if (g.max_energy_gain) {
        base_bound_ = *g.max_energy_gain;
    } else {
        base_bound_ = initial.kinetic + headroom + magnet_binding(scene_);
        motor_power_ = motor_power(scene_.controller);
    }
    remember(world, 0);
}

double Guard::energy_bound(double time) const { return base_bound_ + motor_power_ * time; }

nlohmann::json Guard::state() const {
    return {{"initial_energy", initial_energy_}, {"base_bound", base_bound_}, {"motor_power", motor_power_}};
}

void Guard::restore(const nlohmann::json& s) {
    initial_energy_ = s.at("initial_energy").get<double>();
    base_bound_ = s.at("base_bound").get<double>();
    motor_power_ = s.at("motor_power").get<double>();
}

nlohmann::json Guard::describe() const {
    return {{"finite_check", "every step"},
            {"energy_check", scene_.guard.energy ? "every observed step" : "off"},
            {"energy_bound_j", base_bound_}, {"motor_power_w", motor_power_},
            {"max_speed", scene_.guard.max_speed}, {"dump", dump_path_}};
}

void Guard::check_step(const World& world, long step, bool known_finite, double known_max_speed) const {
    const double vmax = scene_.guard.max_speed;
    std::int64_t bad[2] = {0, 0};  // non-finite, too fast
    const bool speeds_known = known_finite && known_max_speed >= 0 && known_max_speed <= vmax;
    if (!known_finite || (vmax > 0 && !speeds_known)) {
        const std::size_t n = world.body_count(), chunks = chunk_count(loops_, n, 4096);
        std::vector<std::array<std::int64_t, 2>> part(chunks, {0, 0});
        loops_.run(chunks, n, [&](std::size_t c) {
            for (std::size_t i = chunk_begin(n, chunks, c); i < chunk_begin(n, chunks, c + 1); ++i) {
                if (world.ghost(i)) continue;
                if (!finite_state(world.body(i))) ++part[c][0];
                else if (vmax > 0 && speed(world.body(i)) > vmax) ++part[c][1];
            }
        });
        for (const auto& p : part) {
            bad[0] += p[0];
            bad[1] += p[1];
        }
    }
    domain_.sum(bad, 2);  // collective: every process calls it
    if (bad[0]) {
        std::ostringstream os;
        os << bad[0] << " bodies have a non-finite state (first ids:" << first_nan_ids(world, domain_, 10) << ")";
        fail(world, step, os.str());
    }
    if (bad[1]) {
        std::ostringstream os;
        os << bad[1] << " bodies move faster than guard.max_speed = " << vmax << " m/s (fastest: "
           << fastest_bodies(world, domain_, 5, vmax) << ")";
        fail(world, step, os.str());
    }
}

void Guard::check_observed(const World& world, const Diagnostics& d, long step) {
    if (!std::isfinite(d.energy())) {
        std::ostringstream os;
        os << "the total energy is not finite (kinetic " << d.kinetic << " J, potential " << d.potential
           << " J): a magnitude in the scene is beyond what double precision can square (fastest bodies: "
           << fastest_bodies(world, domain_, 5) << ")";
        fail(world, step, os.str());
    }
    const double gain = d.energy() - initial_energy_;
    const double bound = energy_bound(step * scene_.dt);
    if (scene_.guard.energy && gain > bound) {
        std::ostringstream os;
        os << "runaway energy: total energy " << d.energy() << " J is " << gain << " J above the initial "
           << initial_energy_ << " J, past the bound of " << bound << " J (fastest bodies: "
           << fastest_bodies(world, domain_, 5) << ")";
        fail(world, step, os.str());
    }
    remember(world, step);
}

void Guard::remember(const World& world, long step) {
    if (dump_path_.empty()) return;
    good_.step = step;
    good_.rows.clear();
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (world.ghost(i)) continue;
        dBodyID b = world.body(i);
        good_.rows.push_back(world.gid(i));
        const dReal* arrays[4] = {dBodyGetPosition(b), dBodyGetQuaternion(b), dBodyGetLinearVel(b), dBodyGetAngularVel(b)};
        const int sizes[4] = {3, 4, 3, 3};
        for (int a = 0; a < 4; ++a) good_.rows.insert(good_.rows.end(), arrays[a], arrays[a] + sizes[a]);
    }
}

// Collective: the root writes every process's last good rows, by gid.
std::string Guard::dump() const {
    std::vector<char> mine(good_.rows.size() * sizeof(double));
    if (!mine.empty()) std::memcpy(mine.data(), good_.rows.data(), mine.size());
    const auto parts = domain_.gather(mine);
    std::string result;
    if (domain_.root()) {
        std::map<std::uint32_t, const double*> rows;
        for (const auto& part : parts) {
            const auto* d = reinterpret_cast<const double*>(part.data());
            for (std::size_t at = 0; at + 14 <= part.size() / sizeof(double); at += 14) rows[static_cast<std::uint32_t>(d[at])] = d + at + 1;
        }
        std::ofstream out(dump_path_);
        out << "# parode last good state: scene " << scene_.name << ", step " << good_.step << ", time "
            << good_.step * scene_.dt << " s\nbody,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz\n";
        char buf[32];
        for (const auto& [gid, row] : rows) {
            out << gid;
            for (int k = 0; k < 13; ++k) {
                std::snprintf(buf, sizeof buf, ",%.17g", row[k]);
                out << buf;
            }
            out << '\n';
        }
        result = out ? "; last good state (step " + std::to_string(good_.step) + ") written to " + dump_path_
                     : "; the last good state could not be written to " + dump_path_;
    }
    return result;
}

void Guard::fail(const World&, long step, const std::string& what) const {
    std::ostringstream os;
    os << "step " << step << " (t = " << step * scene_.dt << " s): " << what << "; stopping";
    if (!dump_path_.empty()) os << dump();
    throw SimulationError(os.str());
}

}  // namespace parode
