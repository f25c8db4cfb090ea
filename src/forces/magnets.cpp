// Magnet force model, serial reference (see magnets.hpp).
#include "forces/magnets.hpp"

#include <algorithm>
#include <cmath>

#include "util/split_mix.hpp"

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
    at_.resize(members_.size());
    for (std::size_t k = 0; k < at_.size(); ++k) at_[k] = static_cast<std::uint32_t>(k);
    generation_ = world.generation();
    magnet_version_ = world.magnet_version();
}

void MagnetField::prepare(const World& world, const LoopRunner& loops) {
    if (world.generation() != generation_ || world.magnet_version() != magnet_version_) find_members(world);
    for_ranges(loops, members_.size(), 2048, [&](std::size_t k0, std::size_t k1) {
        for (std::size_t k = k0; k < k1; ++k) {
            if (k + kRecordAhead < k1) world.prefetch_body(members_[k + kRecordAhead]);
            place(world, k);
        }
    });
    sort_cells();
    index_cells();
}

void MagnetField::place(const World& world, std::size_t k) {
    const std::size_t np = model_.directions.size();
    dBodyID b = world.body(members_[k]);
    const dReal* p = dBodyGetPosition(b);
    const dReal* R = dBodyGetRotation(b);
    centre_[k] = {p[0], p[1], p[2]};
    for (std::size_t a = 0; a < np; ++a) {
        const Vec3 d = rotate(R, model_.directions[a]);
        poles_[k * np + a] = {p[0] + radius_[k] * d[0], p[1] + radius_[k] * d[1], p[2] + radius_[k] * d[2]};
    }
    cells_[at_[k]] = {cell_key(centre_[k]), world.gid(members_[k]), static_cast<std::uint32_t>(k)};
}

// The entries were written in last step's sorted order, so most steps only
// a few bodies changed cells: insertion moves them in place while they are
// few (up to 8 moves an entry), and std::sort takes over beyond.
void MagnetField::sort_cells() {
    const std::size_t n = cells_.size();
    std::size_t moves = 0, i = 1;
    for (; i < n && moves <= 8 * n; ++i) {
        const CellEntry e = cells_[i];
        std::size_t j = i;
        for (; j > 0 && e < cells_[j - 1]; --j, ++moves) cells_[j] = cells_[j - 1];
        cells_[j] = e;
    }
    if (i < n) std::sort(cells_.begin(), cells_.end());
    for (std::size_t e = 0; e < n; ++e) at_[cells_[e].member] = static_cast<std::uint32_t>(e);
}

void MagnetField::index_cells() {
    std::size_t runs = 0;
    for (std::size_t i = 0; i < cells_.size(); ++i) runs += i == 0 || cells_[i].key != cells_[i - 1].key;
    std::size_t size = 16;
    while (size < 2 * runs) size *= 2;
    index_.assign(size, Run{-1, 0, 0});
    for (std::size_t i = 0; i < cells_.size();) {
        std::size_t j = i;
        while (j < cells_.size() && cells_[j].key == cells_[i].key) ++j;
        std::size_t h = SplitMix64::mix(static_cast<std::uint64_t>(cells_[i].key)) & (size - 1);
        while (index_[h].key != -1) h = (h + 1) & (size - 1);
        index_[h] = {cells_[i].key, static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j)};
        i = j;
    }
}

std::pair<std::uint32_t, std::uint32_t> MagnetField::run_of(std::int64_t key) const {
    const std::size_t mask = index_.size() - 1;
    for (std::size_t h = SplitMix64::mix(static_cast<std::uint64_t>(key)) & mask;; h = (h + 1) & mask) {
        if (index_[h].key == key) return {index_[h].begin, index_[h].end};
        if (index_[h].key == -1) return {0, 0};
    }
}

// A pole of k farther than r_m + cutoff from m's centre is beyond the cutoff
// of every pole of m (they lie on m's surface): its pairs, which the cutoff
// test would all skip, are not looked at (the bound is widened by a part in
// 10^9 against rounding, so no pair within the cutoff is left out and every
// sum is the same).
void MagnetField::add_pair(std::size_t k, std::size_t m, BodyWrench& w) const {
    const std::size_t np = model_.directions.size();
    const double rc2 = model_.cutoff * model_.cutoff;
    const double eps2 = model_.softening * model_.softening;
    const unsigned on_k = partial_ ? on_[k] : 0xFFu, on_m = partial_ ? on_[m] : 0xFFu;  // poles past 8: always on
    const Vec3& om = centre_[m];
    const double far2 = (radius_[m] + model_.cutoff) * (radius_[m] + model_.cutoff) * (1 + 1e-9);
    for (std::size_t a = 0; a < np; ++a) {
        if (a < 8 && !(on_k >> a & 1u)) continue;
        const Vec3& pa = poles_[k * np + a];
        const double e[3] = {pa[0] - om[0], pa[1] - om[1], pa[2] - om[2]};
        if (e[0] * e[0] + e[1] * e[1] + e[2] * e[2] > far2) continue;
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

// The 27 cells around the body's, in the order (x, y, z) of their offsets (the
// three along z of each (x, y) are consecutive keys: z is the key's low
// field), each cell's bodies by global id.
BodyWrench MagnetField::gather(std::size_t k) const {
    BodyWrench w;
    const Vec3& c = centre_[k];
    for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
            const double x = c[0] + dx * cell_, y = c[1] + dy * cell_;
            const std::int64_t first = cell_key(Vec3{x, y, c[2] - cell_}), last = cell_key(Vec3{x, y, c[2] + cell_});
            for (std::int64_t key = first; key <= last; ++key) visit(k, run_of(key), w);
        }
    }
    return w;
}

void MagnetField::visit(std::size_t k, std::pair<std::uint32_t, std::uint32_t> run, BodyWrench& w) const {
    const Vec3& c = centre_[k];
    for (std::uint32_t e = run.first; e < run.second; ++e) {
        const std::size_t m = cells_[e].member;
        if (m == k) continue;
        const Vec3& o = centre_[m];
        const double d2 = (c[0] - o[0]) * (c[0] - o[0]) + (c[1] - o[1]) * (c[1] - o[1]) + (c[2] - o[2]) * (c[2] - o[2]);
        if (d2 < reach2_) add_pair(k, m, w);
    }
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
    field_.prepare(world, loops());
    wrenches_.resize(field_.targets().size());
    gather_all(field_, wrenches_);
    return wrenches_;
}

void MagnetPass::apply(World& world, double /*time*/) { field_.apply(world, wrenches(world)); }

}  // namespace parode
