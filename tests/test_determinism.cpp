// Determinism: the same run twice gives the same state hash; ODE's hash,
// sweep-and-prune and simple spaces give the same state hash once contacts are
// in canonical order; a different seed gives a different hash (so the hash can
// tell runs apart). Trade-off: 200 steps of 1,000 catoms per run keeps each
// case under a second or two while the pile is already chaotic.
#include <gtest/gtest.h>

#include "util/hash.hpp"
#include "test_support.hpp"

using namespace parode;

namespace {

TEST(Determinism, SameRunTwiceSameHash) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=1000"});
    EXPECT_EQ(test::hash_after(sc, 200), test::hash_after(sc, 200));
}

TEST(Determinism, DifferentSeedDifferentHash) {
    const Scene a = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=64"});
    const Scene b = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=64", "scene.seed=2"});
    EXPECT_NE(test::hash_after(a, 50), test::hash_after(b, 50));
}

class SpaceBackends : public ::testing::TestWithParam<const char*> {};

TEST_P(SpaceBackends, HashAndSweepAndPruneGiveTheSameState) {
    const Scene sc = test::repo_scene(std::string("jobs/scenes/") + GetParam() + ".toml", {"catoms.count=1000"});
    const std::uint64_t hash = test::hash_after(sc, 200, "ode-hash");
    EXPECT_EQ(hex64(test::hash_after(sc, 200, "ode-sap")), hex64(hash));
    EXPECT_EQ(hex64(test::hash_after(sc, 200, "ode-simple")), hex64(hash));
}

INSTANTIATE_TEST_SUITE_P(Classic, SpaceBackends, ::testing::Values("tennis", "magnetic-tennis"));

TEST(Determinism, ContactsAreInCanonicalOrder) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=125"});
    auto p = test::run(sc, 100, "ode-sap");
    const auto& items = p->contacts().items();
    ASSERT_FALSE(items.empty());
    const World& w = p->world();
    for (std::size_t i = 0; i < items.size(); ++i) {
        EXPECT_LT(items[i].lo, items[i].hi);
        EXPECT_EQ(geom_id(w.geom_of(items[i].lo)), items[i].lo);  // the geoms the ids name
        EXPECT_EQ(geom_id(w.geom_of(items[i].hi)), items[i].hi);
        if (i > 0) {
            EXPECT_FALSE(canonical_less(items[i], items[i - 1]));
        }
    }
}

}  // namespace
