// World's own records against what ODE holds: the mass World keeps per body
// (mass_of, which the contact solver and the diagnostics read instead of the
// body's record) is, byte for byte, the dMass ODE's body holds, for every
// shape a scene can give a body and for catoms, on a whole world and on a
// subset of the bodies as a rank holds them.
// Deferred moves: while World::defer_moves holds the marks back, ODE's spaces
// learn of written poses only at sync_moves, and then every sphere's AABB
// (ODE's own, through dGeomGetAABB) is where its body is.
// Room for ghosts: a rank's world keeps room for an eighth more bodies than
// it starts with, and reserve_bodies for what an exchange brings, so that
// ghosts arriving one at a time never copy the per-body arrays.
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

TEST(World, GhostsArriveWithoutCopyingTheBodyArrays) {
    const Scene tennis = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=1000"});
    std::vector<std::uint32_t> part(800);
    for (std::uint32_t i = 0; i < 800; ++i) part[i] = i;  // a rank's 800 bodies; 100 ghosts come
    World rank(tennis, SpaceKind::Simple, &part);
    const dBodyID* bodies = rank.bodies().data();
    const std::uint32_t* gids = rank.gids().data();
    for (std::uint32_t g = 800; g < 900; ++g) rank.add_body(g, true);
    EXPECT_EQ(rank.bodies().data(), bodies);
    EXPECT_EQ(rank.gids().data(), gids);
    // An exchange that brings more than the room makes room once, for all of them.
    rank.reserve_bodies(1000);
    bodies = rank.bodies().data();
    gids = rank.gids().data();
    for (std::uint32_t g = 900; g < 1000; ++g) rank.add_body(g, true);
    EXPECT_EQ(rank.bodies().data(), bodies);
    EXPECT_EQ(rank.gids().data(), gids);
    EXPECT_EQ(mass_mismatches(rank), 0);
}

// Bodies whose geom's AABB, as ODE gives it, is not their position +- radius.
int stale_aabbs(const World& w) {
    int bad = 0;
    for (std::size_t i = 0; i < w.body_count(); ++i) {
        dGeomID g = dBodyGetFirstGeom(w.body(i));
        const dReal* x = dBodyGetPosition(w.body(i));
        const dReal r = dGeomSphereGetRadius(g);
        dReal aabb[6];
        dGeomGetAABB(g, aabb);
        for (int k = 0; k < 3; ++k) bad += aabb[2 * k] != x[k] - r || aabb[2 * k + 1] != x[k] + r;
    }
    return bad;
}

// Moves every body by `dx` along x through write_pose, then poses_written.
void shift_all(World& w, double dx) {
    for (std::size_t i = 0; i < w.body_count(); ++i) {
        const dReal* p = dBodyGetPosition(w.body(i));
        const dReal* q = dBodyGetQuaternion(w.body(i));
        const double x[3] = {p[0] + dx, p[1], p[2]}, quat[4] = {q[0], q[1], q[2], q[3]};
        w.write_pose(i, x, quat);
    }
    w.poses_written();
}

TEST(World, DeferredMovesReachOdeAtSync) {
    const Scene tennis = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=8"});
    World w(tennis, SpaceKind::Simple);
    ASSERT_TRUE(w.bodies_are_spheres());
    EXPECT_EQ(stale_aabbs(w), 0);  // also clears ODE's "AABB bad" flags

    shift_all(w, 0.25);  // not deferred: told at once
    EXPECT_EQ(stale_aabbs(w), 0);

    w.defer_moves(true);
    shift_all(w, 0.5);
    EXPECT_EQ(stale_aabbs(w), static_cast<int>(w.body_count()));  // ODE's cached AABBs, untold
    w.sync_moves();
    EXPECT_EQ(stale_aabbs(w), 0);

    shift_all(w, -0.5);
    w.defer_moves(false);  // tells the spaces of what is pending
    EXPECT_EQ(stale_aabbs(w), 0);

    const Scene buggy_scene = test::repo_scene("jobs/scenes/buggy.toml");
    const World buggy(buggy_scene, SpaceKind::Simple);
    EXPECT_FALSE(buggy.bodies_are_spheres());
}

}  // namespace
