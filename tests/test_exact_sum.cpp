// ExactSum, Fnv1aSum and World storage: the exact sum does not depend on the
// order of its terms or on how they are split and merged (as threads and
// ranks do), and rounds the exact total correctly; Fnv1aSum, which hashes
// records several at a time, sums the same digests as Fnv1a one by one;
// World keeps gid <-> local maps right as bodies are added and removed. Trade-off: small random inputs with known
// exact totals, checked against an independent computation. World::write_pose
// and mark_moved leave ODE's bodies and spaces as its own setters do, bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "scene/scene_file.hpp"
#include "util/exact_sum.hpp"
#include "util/hash.hpp"
#include "world/world.hpp"

using parode::ExactSum;

namespace {

double exact(const std::vector<double>& v) {
    ExactSum s;
    for (double x : v) s.add(x);
    return s.value();
}

std::vector<double> wide_values(unsigned seed, std::size_t n) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> mant(-1.0, 1.0);
    std::uniform_int_distribution<int> expo(-60, 60);
    std::vector<double> v(n);
    for (double& x : v) x = std::ldexp(mant(rng), expo(rng));
    return v;
}

TEST(ExactSum, TenthsSumToOneWhereNaiveSumDoesNot) {
    std::vector<double> v(10, 0.1);
    double naive = 0;
    for (double x : v) naive += x;
    EXPECT_NE(naive, 1.0);
    EXPECT_EQ(exact(v), 1.0);  // 10 x 0.1000000000000000055511 rounds to 1
}

TEST(ExactSum, CancellationKeepsTheSmallTerm) {
    EXPECT_EQ(exact({1e100, 1.0, -1e100}), 1.0);
    EXPECT_EQ(exact({1e300, 1e-300, -1e300}), 1e-300);
    EXPECT_EQ(exact({std::ldexp(1.0, -1074), std::ldexp(1.0, -1074)}), std::ldexp(1.0, -1073));
    EXPECT_EQ(exact({-3.5, 1.25}), -2.25);
    EXPECT_EQ(exact({}), 0.0);
}

TEST(ExactSum, OrderAndSplitDoNotMatter) {
    std::vector<double> v = wide_values(1, 5000);
    const double reference = exact(v);
    std::mt19937_64 rng(2);
    for (int trial = 0; trial < 5; ++trial) {
        std::shuffle(v.begin(), v.end(), rng);
        ExactSum parts[3];
        for (std::size_t i = 0; i < v.size(); ++i) parts[i % 3].add(v[i]);
        parts[1].normalise();
        parts[0].merge(parts[2]);
        parts[0].merge(parts[1]);
        EXPECT_EQ(parts[0].value(), reference) << "trial " << trial;
    }
}

// Integers up to 2^53 sum exactly in long double chunks: an independent total.
TEST(ExactSum, RoundsTheExactTotal) {
    std::mt19937_64 rng(3);
    std::vector<double> v;
    long long total = 0;
    for (int i = 0; i < 1000; ++i) {
        const long long x = static_cast<long long>(rng() % (1ULL << 40)) - (1LL << 39);
        total += x;
        v.push_back(static_cast<double>(x) * 0.25);  // exact in a double
    }
    EXPECT_EQ(exact(v), static_cast<double>(total) * 0.25);
}

TEST(ExactSum, RoundsToNearestEven) {
    const double u = std::ldexp(1.0, -53);  // half an ulp of 1
    EXPECT_EQ(exact({1.0, u, std::ldexp(1.0, -60)}), 1.0 + 2 * u) << "above half: up";
    EXPECT_EQ(exact({1.0, u}), 1.0) << "a tie goes to the even mantissa";
    EXPECT_EQ(exact({1.0 + 2 * u, u}), 1.0 + 4 * u) << "a tie goes to the even mantissa";
    EXPECT_EQ(exact({1.0, u, -std::ldexp(1.0, -60)}), 1.0) << "below half: down";
}

TEST(ExactSum, SpecialValues) {
    EXPECT_TRUE(std::isnan(exact({1.0, std::nan("")})));
    EXPECT_EQ(exact({1.0, HUGE_VAL}), HUGE_VAL);
    EXPECT_TRUE(std::isnan(exact({HUGE_VAL, -HUGE_VAL})));
    EXPECT_EQ(exact({1.7e308, 1.7e308}), HUGE_VAL);  // overflows a double
}

// Every count from none to a few batches, so full and partial batches both
// occur, against the sum of one Fnv1a per record.
TEST(Fnv1aSum, SumsTheSameDigestsAsOneByOne) {
    constexpr std::size_t kBytes = 108;
    std::mt19937_64 rng(7);
    for (std::size_t n = 0; n <= 27; ++n) {
        parode::Fnv1aSum<kBytes> batched;
        std::uint64_t expected = 0;
        for (std::size_t r = 0; r < n; ++r) {
            unsigned char rec[kBytes];
            for (unsigned char& b : rec) b = static_cast<unsigned char>(rng());
            std::memcpy(batched.next(), rec, kBytes);
            parode::Fnv1a one;
            one.add_bytes(rec, kBytes);
            expected += one.value();
        }
        EXPECT_EQ(batched.value(), expected) << n << " records";
    }
}

TEST(WorldStorage, AddRemoveKeepsMapsAndGeoms) {
    const parode::Scene sc = parode::load_scene_text(
        "[scene]\nname = \"s\"\n[catoms]\ncount = 27\n[[planes]]\nnormal = [0.0, 0.0, 1.0]\n", "s");
    const std::vector<std::uint32_t> gids{5, 9, 2, 20};
    parode::World w(sc, parode::SpaceKind::Simple, &gids);
    ASSERT_EQ(w.body_count(), 4u);
    EXPECT_EQ(w.geoms().size(), 5u);  // 4 bodies, 1 plane
    EXPECT_EQ(parode::geom_id(w.geoms().back()), 27u) << "statics follow every body of the scene";
    w.remove_body(1);  // gid 9: the last (gid 20) moves to local 1
    EXPECT_EQ(w.gid(1), 20u);
    EXPECT_EQ(w.local_of(20), 1u);
    EXPECT_EQ(w.local_of(9), parode::IdMap::kNone);
    const std::size_t g = w.add_body(9, true);
    EXPECT_TRUE(w.ghost(g));
    EXPECT_EQ(w.owned_count(), 3u);
    EXPECT_EQ(w.geoms().size(), 5u);
    const parode::Vec3 p = sc.body(9).position;
    EXPECT_EQ(dBodyGetPosition(w.body(g))[0], p[0]) << "a body is rebuilt from the scene by gid";
    parode::BodyState s = w.state(0);
    s.x[2] += 1.0;
    w.set_state(g, s);
    EXPECT_EQ(w.state(g).q[0], s.q[0]);
    EXPECT_EQ(dBodyGetPosition(w.body(g))[2], s.x[2]);
}

TEST(WorldStorage, WritePoseLeavesWhatOdesSettersLeave) {
    const parode::Scene sc = parode::load_scene_text("[scene]\nname = \"s\"\n[catoms]\ncount = 64\n", "s");
    parode::World a(sc, parode::SpaceKind::Hash), b(sc, parode::SpaceKind::Hash);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-2.0, 2.0);
    for (int round = 0; round < 50; ++round) {
        dSpaceClean(a.space());  // as a collision pass does: moved geoms are clean again
        dSpaceClean(b.space());
        for (std::size_t i = round % 3; i < a.body_count(); i += 1 + round % 5) {
            const double x[3] = {u(rng), u(rng), u(rng)}, q[4] = {u(rng), u(rng), u(rng), u(rng)};
            a.set_pose(i, x, q);
            b.write_pose(i, x, q);
            b.mark_moved(i);
        }
    }
    for (std::size_t i = 0; i < a.body_count(); ++i) {
        EXPECT_EQ(std::memcmp(dBodyGetPosition(a.body(i)), dBodyGetPosition(b.body(i)), 3 * sizeof(dReal)), 0) << i;
        EXPECT_EQ(std::memcmp(dBodyGetQuaternion(a.body(i)), dBodyGetQuaternion(b.body(i)), 4 * sizeof(dReal)), 0) << i;
        EXPECT_EQ(std::memcmp(dBodyGetRotation(a.body(i)), dBodyGetRotation(b.body(i)), 12 * sizeof(dReal)), 0) << i;
    }
    ASSERT_EQ(dSpaceGetNumGeoms(a.space()), dSpaceGetNumGeoms(b.space()));
    for (int k = 0; k < dSpaceGetNumGeoms(a.space()); ++k) {
        EXPECT_EQ(parode::geom_id(dSpaceGetGeom(a.space(), k)), parode::geom_id(dSpaceGetGeom(b.space(), k)))
            << "the space's geom order (ODE's pair order) at " << k;
    }
}

}  // namespace
