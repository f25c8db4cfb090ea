// Diagnostics (see diagnostics.hpp).
#include "run/diagnostics.hpp"

#include <cmath>

#include "util/hash.hpp"

namespace parode {
namespace {

static_assert(sizeof(dReal) == sizeof(double), "parode needs ODE in double precision");

bool finite_state(dBodyID b) {
    const dReal* arrays[4] = {dBodyGetPosition(b), dBodyGetQuaternion(b), dBodyGetLinearVel(b), dBodyGetAngularVel(b)};
    const int sizes[4] = {3, 4, 3, 3};
    for (int a = 0; a < 4; ++a) {
        for (int i = 0; i < sizes[a]; ++i) if (!std::isfinite(arrays[a][i])) return false;
    }
    return true;
}

// Kinetic energy and angular momentum contribution of one body.
double add_body(dBodyID b, const Vec3& up, double g, Diagnostics& d) {
    dMass m;
    dBodyGetMass(b, &m);
    const dReal* x = dBodyGetPosition(b);
    const dReal* v = dBodyGetLinearVel(b);
    const dReal* w = dBodyGetAngularVel(b);
    const dReal* R = dBodyGetRotation(b);
    // I_world * w = R * I_body * R^T * w
    double wb[3], iw[3], L[3];
    for (int i = 0; i < 3; ++i) wb[i] = R[0 + i] * w[0] + R[4 + i] * w[1] + R[8 + i] * w[2];
    for (int i = 0; i < 3; ++i) iw[i] = m.I[4 * i] * wb[0] + m.I[4 * i + 1] * wb[1] + m.I[4 * i + 2] * wb[2];
    for (int i = 0; i < 3; ++i) L[i] = R[4 * i] * iw[0] + R[4 * i + 1] * iw[1] + R[4 * i + 2] * iw[2];
    const double h = x[0] * up[0] + x[1] * up[1] + x[2] * up[2];
    d.kinetic += 0.5 * m.mass * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + 0.5 * (w[0] * L[0] + w[1] * L[1] + w[2] * L[2]);
    d.potential += m.mass * g * h;
    d.com_height += m.mass * h;
    for (int i = 0; i < 3; ++i) d.momentum[i] += m.mass * v[i];
    d.angular_momentum[0] += m.mass * (x[1] * v[2] - x[2] * v[1]) + L[0];
    d.angular_momentum[1] += m.mass * (x[2] * v[0] - x[0] * v[2]) + L[1];
    d.angular_momentum[2] += m.mass * (x[0] * v[1] - x[1] * v[0]) + L[2];
    return m.mass;
}

}  // namespace

std::uint64_t state_hash(const World& world) {
    Fnv1a h;
    for (dBodyID b : world.bodies()) {
        h.add_doubles(dBodyGetPosition(b), 3);
        h.add_doubles(dBodyGetQuaternion(b), 4);
        h.add_doubles(dBodyGetLinearVel(b), 3);
        h.add_doubles(dBodyGetAngularVel(b), 3);
    }
    return h.value();
}

std::vector<std::size_t> nan_bodies(const World& world, std::size_t limit) {
    std::vector<std::size_t> out;
    for (std::size_t i = 0; i < world.body_count() && out.size() < limit; ++i) {
        if (!finite_state(world.body(i))) out.push_back(i);
    }
    return out;
}

Diagnostics observe(const World& world, const ContactBuffer& contacts) {
    Diagnostics d;
    const Vec3& gv = world.scene().gravity;
    const double g = std::sqrt(gv[0] * gv[0] + gv[1] * gv[1] + gv[2] * gv[2]);
    const Vec3 up = g > 0 ? Vec3{-gv[0] / g, -gv[1] / g, -gv[2] / g} : Vec3{0, 0, 1};
    double mass = 0;
    for (dBodyID b : world.bodies()) {
        if (!finite_state(b)) {
            ++d.nan_count;
            continue;
        }
        d.disabled += dBodyIsEnabled(b) ? 0 : 1;
        mass += add_body(b, up, g, d);
    }
    if (mass > 0) d.com_height /= mass;
    double sum = 0;
    for (const ContactRecord& c : contacts.items()) {
        if (world.ignores(c)) continue;
        d.max_penetration = std::max(d.max_penetration, c.geom.depth);
        sum += c.geom.depth;
        ++d.contacts;
    }
    d.mean_penetration = d.contacts ? sum / static_cast<double>(d.contacts) : 0;
    d.state_hash = state_hash(world);
    return d;
}

}  // namespace parode
