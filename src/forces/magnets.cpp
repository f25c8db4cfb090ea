// Magnet force model, serial reference (see magnets.hpp).
#include "forces/magnets.hpp"

#include <algorithm>
#include <cmath>

namespace parode {
namespace {

Vec3 rotate(const dReal* R, const Vec3& v) {  // ODE's 3x4 row-major rotation
    return {R[0] * v[0] + R[1] * v[1] + R[2] * v[2], R[4] * v[0] + R[5] * v[1] + R[6] * v[2],
            R[8] * v[0] + R[9] * v[1] + R[10] * v[2]};
}

}  // namespace

MagnetField::MagnetField(const Scene& scene) : scene_(scene), model_(scene.magnets) {
    double rmax = 0;
    if (scene.catoms.count && scene.catoms.proto.magnets) rmax = scene.catoms.proto.shape.radius;
    for (const BodySpec& b : scene.bodies) {
        if (b.magnets) rmax = std::max(rmax, b.shape.radius);
    }
    cell_ = 2 * rmax + model_.cutoff;
    reach2_ = cell_ * cell_;
}

std::int64_t MagnetField::cell_key(const Vec3& c) const {
    constexpr std::int64_t kBias = 1 << 20;
    auto q = [this](double x) { return static_cast<std::int64_t>(std::floor(x / cell_)) + kBias; };
    return (q(c[0]) << 42) | (q(c[1]) << 21) | q(c[2]);
}

void MagnetField::find_members(const World& world) {
    members_.clear();
    targets_.clear();
    radius_.clear();
    on_.clear();
    partial_ = false;
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        const std::uint32_t gid = world.gid(i);
        const std::uint8_t off = world.poles_off(gid);
        if (!scene_.body_magnets(gid) || off == World::kAllPolesOff) continue;
        on_.push_back(static_cast<std::uint8_t>(~off));
        partial_ = partial_ || off != 0;
        if (!world.ghost(i)) targets_.push_back(static_cast<std::uint32_t>(members_.size()));
        members_.push_back(static_cast<std::uint32_t>(i));
        radius_.push_back(gid < scene_.bodies.size() ? scene_.bodies[gid].shape.radius : scene_.catoms.proto.shape.radius);
    }
    centre_.resize(members_.size());
    poles_.resize(members_.size() * model_.directions.size());
    cells_.resize(members_.size());
    generation_ = world.generation();
    magnet_version_ = world.magnet_version();
}

void MagnetField::prepare(const World& world) {
    if (world.generation() != generation_ || world.magnet_version() != magnet_version_) find_members(world);
    const std::size_t np = model_.directions.size();
    for (std::size_t k = 0; k < members_.size(); ++k) {
        dBodyID b = world.body(members_[k]);
        const dReal* p = dBodyGetPosition(b);
        const dReal* R = dBodyGetRotation(b);
        centre_[k] = {p[0], p[1], p[2]};
        for (std::size_t a = 0; a < np; ++a) {
            const Vec3 d = rotate(R, model_.directions[a]);
            poles_[k * np + a] = {p[0] + radius_[k] * d[0], p[1] + radius_[k] * d[1], p[2] + radius_[k] * d[2]};
        }
        cells_[k] = {cell_key(centre_[k]), world.gid(members_[k]), static_cast<std::uint32_t>(k)};
    }
    std::sort(cells_.begin(), cells_.end());
}

void MagnetField::add_pair(std::size_t k, std::size_t m, BodyWrench& w) const {
    const std::size_t np = model_.directions.size();
    const double rc2 = model_.cutoff * model_.cutoff;
    const double eps2 = model_.softening * model_.softening;
    const unsigned on_k = partial_ ? on_[k] : 0xFFu, on_m = partial_ ? on_[m] : 0xFFu;  // poles past 8: always on
    for (std::size_t a = 0; a < np; ++a) {
        if (a < 8 && !(on_k >> a & 1u)) continue;
        const Vec3& pa = poles_[k * np + a];
        for (std::size_t b = 0; b < np; ++b) {
            if (b < 8 && !(on_m >> b & 1u)) continue;
            const Vec3& pb = poles_[m * np + b];
            const Vec3 d{pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]};
            const double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if (r2 >= rc2) continue;
            const double taper = (1 - r2 / rc2) * (1 - r2 / rc2);
            const double s = r2 + eps2;
            const double f = model_.strength * model_.charges[a] * model_.charges[b] * taper / (s * std::sqrt(s));
            const Vec3 F{f * d[0], f * d[1], f * d[2]};
            const Vec3 r{pa[0] - centre_[k][0], pa[1] - centre_[k][1], pa[2] - centre_[k][2]};
            for (int c = 0; c < 3; ++c) w.force[c] += F[c];
            w.torque[0] += r[1] * F[2] - r[2] * F[1];
            w.torque[1] += r[2] * F[0] - r[0] * F[2];
            w.torque[2] += r[0] * F[1] - r[1] * F[0];
        }
    }
}

BodyWrench MagnetField::gather(std::size_t k) const {
    BodyWrench w;
    const Vec3& c = centre_[k];
    for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
            for (int dz = -1; dz <= 1; ++dz) {
                const Vec3 probe{c[0] + dx * cell_, c[1] + dy * cell_, c[2] + dz * cell_};
                const std::int64_t key = cell_key(probe);
                auto it = std::lower_bound(cells_.begin(), cells_.end(), CellEntry{key, 0, 0});
                for (; it != cells_.end() && it->key == key; ++it) {
                    const std::size_t m = it->member;
                    if (m == k) continue;
                    const Vec3& o = centre_[m];
                    const double d2 = (c[0] - o[0]) * (c[0] - o[0]) + (c[1] - o[1]) * (c[1] - o[1]) + (c[2] - o[2]) * (c[2] - o[2]);
                    if (d2 < reach2_) add_pair(k, m, w);
                }
            }
        }
    }
    return w;
}

void MagnetField::apply(World& world, const std::vector<BodyWrench>& wrenches) const {
    for (std::size_t j = 0; j < targets_.size(); ++j) {
        dBodyID b = world.body(members_[targets_[j]]);
        const BodyWrench& w = wrenches[j];
        dBodyAddForce(b, w.force[0], w.force[1], w.force[2]);
        dBodyAddTorque(b, w.torque[0], w.torque[1], w.torque[2]);
    }
}

void MagnetPass::gather_all(const MagnetField& field, std::vector<BodyWrench>& out) const {
    for (std::size_t j = 0; j < field.targets().size(); ++j) out[j] = field.gather(field.targets()[j]);
}

const std::vector<BodyWrench>& MagnetPass::wrenches(const World& world) {
    field_.prepare(world);
    wrenches_.resize(field_.targets().size());
    gather_all(field_, wrenches_);
    return wrenches_;
}

void MagnetPass::apply(World& world, double /*time*/) { field_.apply(world, wrenches(world)); }

}  // namespace parode
