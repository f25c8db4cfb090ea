// Diagnostics (see diagnostics.hpp).
#include "observe/diagnostics.hpp"

#include <cmath>
#include <cstring>
#include <vector>

#include "util/hash.hpp"
#include "exec/loops.hpp"
#include "util/split_mix.hpp"

namespace parode {
namespace {

static_assert(sizeof(dReal) == sizeof(double), "parode needs ODE in double precision");

// Exact partial sums of one process, reduced over processes in one call.
struct Sums {
    enum { Kinetic, Potential, Mass, MassHeight, Px, Py, Pz, Lx, Ly, Lz, Depth, Count };
    ExactSum s[Count];
};

// Kinetic energy, momenta and height of one body of mass m into the sums.
void add_body(dBodyID b, const dMass& m, const Vec3& up, double g, Sums& sums) {
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
    ExactSum* s = sums.s;
    s[Sums::Kinetic].add(0.5 * m.mass * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) +
                         0.5 * (w[0] * L[0] + w[1] * L[1] + w[2] * L[2]));
    s[Sums::Potential].add(m.mass * g * h);
    s[Sums::Mass].add(m.mass);
    s[Sums::MassHeight].add(m.mass * h);
    for (int i = 0; i < 3; ++i) s[Sums::Px + i].add(m.mass * v[i]);
    s[Sums::Lx].add(m.mass * (x[1] * v[2] - x[2] * v[1]) + L[0]);
    s[Sums::Ly].add(m.mass * (x[2] * v[0] - x[0] * v[2]) + L[1]);
    s[Sums::Lz].add(m.mass * (x[0] * v[1] - x[1] * v[0]) + L[2]);
}

}  // namespace

Vec3 up_direction(const Scene& scene) {
    const Vec3& gv = scene.gravity;
    const double g = std::sqrt(gv[0] * gv[0] + gv[1] * gv[1] + gv[2] * gv[2]);
    return g > 0 ? Vec3{-gv[0] / g, -gv[1] / g, -gv[2] / g} : Vec3{0, 0, 1};
}

bool finite_state(dBodyID b) {
    const dReal* arrays[4] = {dBodyGetPosition(b), dBodyGetQuaternion(b), dBodyGetLinearVel(b), dBodyGetAngularVel(b)};
    const int sizes[4] = {3, 4, 3, 3};
    for (int a = 0; a < 4; ++a) {
        for (int i = 0; i < sizes[a]; ++i) if (!std::isfinite(arrays[a][i])) return false;
    }
    return true;
}

namespace {

// The bytes a body's digest covers: global id, position, quaternion, linear
// and angular velocity.
constexpr std::size_t kDigestBytes = sizeof(std::uint32_t) + 13 * sizeof(double);
using DigestSum = Fnv1aSum<kDigestBytes>;

void digest_record(const World& world, std::size_t local, unsigned char* out) {
    dBodyID b = world.body(local);
    const std::uint32_t gid = world.gid(local);
    std::memcpy(out, &gid, sizeof gid);
    out += sizeof gid;
    // Fixed sizes and offsets: the copies compile to moves (a loop over the
    // four arrays made observe 2.4x slower at 10^6).
    std::memcpy(out, dBodyGetPosition(b), 3 * sizeof(double));
    std::memcpy(out + 24, dBodyGetQuaternion(b), 4 * sizeof(double));
    std::memcpy(out + 56, dBodyGetLinearVel(b), 3 * sizeof(double));
    std::memcpy(out + 80, dBodyGetAngularVel(b), 3 * sizeof(double));
}

}  // namespace

std::uint64_t body_digest(const World& world, std::size_t local) {
    unsigned char rec[kDigestBytes];
    digest_record(world, local, rec);
    Fnv1a h;
    h.add_bytes(rec, sizeof rec);
    return h.value();
}

std::vector<std::uint32_t> nan_bodies(const World& world, std::size_t limit) {
    std::vector<std::uint32_t> out;
    for (std::size_t i = 0; i < world.body_count() && out.size() < limit; ++i) {
        if (!world.ghost(i) && !finite_state(world.body(i))) out.push_back(world.gid(i));
    }
    return out;
}

namespace {

// The state hash from this process's sum of body digests (modulo 2^64).
std::uint64_t hash_of_sum(std::uint64_t sum, const Collectives& domain) {
    domain.sum_wrapping(&sum, 1);
    return SplitMix64::mix(sum);
}

// What one chunk of bodies adds: its partial sums, counts and digest sum.
struct BodyPart {
    Sums sums;
    std::int64_t nan = 0, disabled = 0;
    std::uint64_t digests = 0;  // modulo 2^64
};

// One chunk of bodies, in one pass over their ODE records (the sums and the
// state hash read the same arrays). The part is built in a local and stored
// once by the caller: neighbouring chunks' parts share cache lines.
BodyPart observe_bodies(const World& world, std::size_t i0, std::size_t i1, const Vec3& up, double g) {
    BodyPart part;
    DigestSum digests;
    for (std::size_t i = i0; i < i1; ++i) {
        if (i + kRecordAhead < i1) world.prefetch_body(i + kRecordAhead);
        if (world.ghost(i)) continue;
        dBodyID b = world.body(i);
        digest_record(world, i, digests.next());
        if (!finite_state(b)) {
            ++part.nan;
            continue;
        }
        part.disabled += dBodyIsEnabled(b) ? 0 : 1;
        add_body(b, world.mass_of(world.gid(i)), up, g, part.sums);
    }
    part.digests = digests.value();
    return part;
}

// What one chunk of contacts adds: the sum and maximum of their depths, and
// how many there are.
struct ContactPart {
    ExactSum depth;
    double deepest = 0;
    std::int64_t touching = 0;
};

// One chunk of contacts, built in a local and stored once by the caller:
// updated in place per contact, neighbouring chunks' entries shared a cache
// line that two threads wrote in turn, and the pass ran slower on two
// threads than on one.
ContactPart observe_contacts(const World& world, const std::vector<ContactRecord>& items, std::size_t k0,
                             std::size_t k1) {
    ContactPart part;
    for (std::size_t k = k0; k < k1; ++k) {
        if (world.ignores(items[k])) continue;
        part.deepest = std::max(part.deepest, items[k].geom.depth);
        part.depth.add(items[k].geom.depth);
        ++part.touching;
    }
    return part;
}

}  // namespace

Diagnostics observe(const World& world, const ContactBuffer& contacts, const Collectives& domain,
                    const LoopRunner& loops) {
    const Vec3 up = up_direction(world.scene());
    const Vec3& gv = world.scene().gravity;
    const double g = std::sqrt(gv[0] * gv[0] + gv[1] * gv[1] + gv[2] * gv[2]);
    const std::size_t n = world.body_count(), chunks = chunk_count(loops, n, 4096);
    std::vector<BodyPart> part(chunks);
    loops.run(chunks, n, [&](std::size_t c) {
        part[c] = observe_bodies(world, chunk_begin(n, chunks, c), chunk_begin(n, chunks, c + 1), up, g);
    });
    Sums sums;
    std::int64_t counts[3] = {0, 0, 0};  // nan, disabled, contacts
    std::uint64_t digests = 0;
    for (std::size_t c = 0; c < chunks; ++c) {  // exact sums: the same bits in any order
        for (int k = 0; k < Sums::Count; ++k) sums.s[k].merge(part[c].sums.s[k]);
        counts[0] += part[c].nan;
        counts[1] += part[c].disabled;
        digests += part[c].digests;
    }
    const auto& items = contacts.items();
    const std::size_t m = items.size(), cchunks = chunk_count(loops, m, 4096);
    std::vector<ContactPart> cpart(cchunks);
    loops.run(cchunks, m, [&](std::size_t c) {
        cpart[c] = observe_contacts(world, items, chunk_begin(m, cchunks, c), chunk_begin(m, cchunks, c + 1));
    });
    double max_depth = 0;
    for (const ContactPart& p : cpart) {
        max_depth = std::max(max_depth, p.deepest);
        sums.s[Sums::Depth].merge(p.depth);
        counts[2] += p.touching;
    }
    domain.sum(sums.s, Sums::Count);
    domain.sum(counts, 3);
    Diagnostics d;
    d.max_penetration = domain.max(max_depth);
    d.nan_count = static_cast<std::size_t>(counts[0]);
    d.disabled = static_cast<std::size_t>(counts[1]);
    d.contacts = static_cast<std::size_t>(counts[2]);
    d.kinetic = sums.s[Sums::Kinetic].value();
    d.potential = sums.s[Sums::Potential].value();
    const double mass = sums.s[Sums::Mass].value();
    d.com_height = mass > 0 ? sums.s[Sums::MassHeight].value() / mass : 0.0;
    for (int i = 0; i < 3; ++i) {
        d.momentum[static_cast<std::size_t>(i)] = sums.s[Sums::Px + i].value();
        d.angular_momentum[static_cast<std::size_t>(i)] = sums.s[Sums::Lx + i].value();
    }
    d.mean_penetration = d.contacts ? sums.s[Sums::Depth].value() / static_cast<double>(d.contacts) : 0;
    d.state_hash = hash_of_sum(digests + world.program_digest(), domain);
    return d;
}

}  // namespace parode
