// World's own records against what ODE holds: the mass World keeps per body
// (mass_of, which the contact solver and the diagnostics read instead of the
// body's record) is, byte for byte, the dMass ODE's body holds, for every
// shape a scene can give a body and for catoms, on a whole world and on a
// subset of the bodies as a rank holds them.
// Trade-off: compares bytes, not values, so that a mass rebuilt by other
// arithmetic (one rounding apart) fails too.
#include <gtest/gtest.h>

#include <cstring>

#include "test_support.hpp"
#include "world/world.hpp"

using namespace parode;

namespace {

// Bodies whose mass_of differs from ODE's copy, byte for byte.
int mass_mismatches(const World& w) {
    int bad = 0;
    for (std::size_t i = 0; i < w.body_count(); ++i) {
        dMass ode;
        dBodyGetMass(w.body(i), &ode);
        bad += std::memcmp(&ode, &w.mass_of(w.gid(i)), sizeof(dMass)) != 0;
    }
    return bad;
}

TEST(World, MassOfIsTheMassOdeHolds) {
    const Scene buggy = test::repo_scene("jobs/scenes/buggy.toml");  // box, cylinders, spheres
    const World whole(buggy, SpaceKind::Simple);
    ASSERT_GT(whole.body_count(), 3u);
    EXPECT_EQ(mass_mismatches(whole), 0);

    Scene tennis = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=27", "catoms.mass=0.3"});
    const std::vector<std::uint32_t> part = {26, 3, 14};  // a rank's bodies, out of order
    const World rank(tennis, SpaceKind::Simple, &part);
    ASSERT_EQ(rank.body_count(), 3u);
    EXPECT_EQ(mass_mismatches(rank), 0);
    EXPECT_EQ(rank.mass_of(14).mass, 0.3);
}

}  // namespace
