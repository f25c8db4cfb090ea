// The grid backend's neighbour list (omp/neighbour_list.hpp): while World's
// spheres creep, jump and the floor is switched off and on, every call's
// contacts equal ODE's own space's bit for bit, and the list is both reused and
// rebuilt on the way; a space with too many geoms other than plain spheres
// declines the list and still matches.
// Trade-off: positions are set by hand (no solver), so each case is exactly
// the motion it names.
#include <gtest/gtest.h>

#include <cmath>

#include "collide/collide.hpp"
#include "omp/grid/grid_collide.hpp"
#include "page_advice.hpp"
#include "omp/grid/sphere_search.hpp"
#include "scene/scene_file.hpp"
#include "test_support.hpp"
#include "world/world.hpp"

using namespace parode;

namespace {

std::uint64_t reference_digest(dSpaceID space) {
    ContactBuffer ref;
    collide_space_reference(space, 4, ref);
    return contact_digest(ref);
}

// Every body a little further along its own direction: after a few calls
// some have crept farther than the skin (a tenth of the radius) from where
// the list was built.
void creep(World& w, int call) {
    for (std::size_t i = 0; i < w.body_count(); ++i) {
        dBodyID b = w.body(i);
        const dReal* p = dBodyGetPosition(b);
        const double k = static_cast<double>(i) + 0.37 * call;
        dBodySetPosition(b, p[0] + 0.004 * std::sin(k), p[1] + 0.004 * std::cos(1.3 * k), p[2] - 0.002);
    }
}

TEST(NeighbourList, ContactsEqualTheReferenceWhileSpheresCreepAndJump) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=1000"});
    World w(sc, SpaceKind::Simple);
    ASSERT_NE(w.sphere_bodies(), nullptr);
    omp::CollideEngine e;
    e.set_threads(2);
    e.set_geoms(w.space(), &w.geoms());
    e.set_sphere_bodies(w.sphere_bodies());
    dGeomID floor = w.geoms().back();
    ASSERT_EQ(dGeomGetClass(floor), dPlaneClass);
    for (int call = 0; call < 30; ++call) {
        creep(w, call);
        if (call == 12) {  // body 7 lands next to body 500, far beyond any skin
            const dReal* q = dBodyGetPosition(dGeomGetBody(w.geoms()[500]));
            dBodySetPosition(dGeomGetBody(w.geoms()[7]), q[0] + 0.95, q[1], q[2]);
        }
        if (call == 16) dGeomDisable(floor);
        if (call == 20) dGeomEnable(floor);
        ContactBuffer out;
        e.collide(w.space(), 4, out);
        ASSERT_EQ(contact_digest(out), reference_digest(w.space())) << "call " << call;
        ASSERT_GT(out.size(), 1000u);
    }
    const auto c = e.list_counts();
    EXPECT_GE(c.builds, 2u);
    EXPECT_GE(c.uses, 10u);
    EXPECT_EQ(c.declined, 0u);
}

// 100 boxes beside 100 spheres: more geoms outside the list than it tests
// against each sphere, so the grid runs instead.
TEST(NeighbourList, ManyOtherGeomsDeclineTheList) {
    ensure_ode_initialised();
    dSpaceID space = dSimpleSpaceCreate(nullptr);
    std::vector<dGeomID> geoms;
    for (int i = 0; i < 200; ++i) {
        dGeomID g = i % 2 ? dCreateBox(space, 1, 1, 1) : dCreateSphere(space, 0.5);
        dGeomSetPosition(g, 0.9 * (i % 10), 0.9 * ((i / 10) % 10), 0.9 * (i / 100));
        set_geom_id(g, static_cast<std::uint32_t>(i));
        geoms.push_back(g);
    }
    omp::CollideEngine e;
    e.set_geoms(space, &geoms);
    for (int call = 0; call < 3; ++call) {
        ContactBuffer out;
        e.collide(space, 4, out);
        EXPECT_EQ(contact_digest(out), reference_digest(space));
        EXPECT_GT(out.size(), 100u);
    }
    EXPECT_EQ(e.list_counts().declined, 1u);
    EXPECT_EQ(e.list_counts().builds, 0u);
    dSpaceDestroy(space);
}

// Other geoms in the table's slots with the table's size unchanged (on a
// rank, a migration that sends as many bodies away as it brings): the list
// is patched (the two geoms keep their references and pairs under their new
// slots), not built again nor left to the grid for a while as after spheres
// that outran their skin (there the merge sorts, and its buffers set a
// rank's peak memory).
TEST(NeighbourList, OtherGeomsInTheTablesSlotsArePatchedIn) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=1000"});
    World w(sc, SpaceKind::Simple);
    std::vector<dGeomID> geoms = w.geoms();
    omp::CollideEngine e;
    e.set_threads(2);
    e.set_geoms(w.space(), &geoms);
    for (int call = 0; call < 5; ++call) {
        if (call == 2) std::swap(geoms[3], geoms[700]);
        ContactBuffer out;
        e.collide(w.space(), 4, out);
        ASSERT_EQ(contact_digest(out), reference_digest(w.space())) << "call " << call;
        const omp::CollideEngine::ListCounts c = e.list_counts();
        EXPECT_EQ(c.builds, 1u) << "call " << call;
        EXPECT_EQ(c.uses, std::size_t(call)) << "call " << call;
        EXPECT_EQ(c.patches, call < 2 ? 0u : 1u) << "call " << call;
        EXPECT_EQ(c.merges_sorted, 0u) << "call " << call;
    }
}

// A rank's table as bodies cross its boundaries: every call some bodies
// leave (the last moving into each gap), others arrive (owned or ghosts,
// beside and inside the pile, touching the bodies held), and all creep. The
// list is patched each call, and its contacts equal ODE's own space's; a call
// that changes more than an eighth of the table builds it afresh.
TEST(NeighbourList, BodiesLeavingAndArrivingArePatchedIn) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=8000"});
    std::vector<std::uint32_t> gids, later;
    for (std::uint32_t i = 0; i < 8000; ++i) (i % 4 ? gids : later).push_back(static_cast<std::uint32_t>((std::uint64_t{i} * 7919) % 8000));
    World w(sc, SpaceKind::Hash, &gids);
    omp::CollideEngine e;
    e.set_threads(2);
    e.set_geoms(w.space(), &w.geoms());
    e.set_sphere_bodies(w.sphere_bodies());
    std::size_t next = 0;
    for (int call = 0; call < 8; ++call) {
        const std::size_t leave = call == 6 ? w.body_count() / 6 : 40, come = call == 6 ? 900 : 60;
        for (std::size_t k = 0; call > 0 && k < leave; ++k) w.remove_body((k * 131 + static_cast<std::size_t>(call)) % w.body_count());
        for (std::size_t k = 0; call > 0 && k < come && next < later.size(); ++k) w.add_body(later[next++], k % 3 == 0);
        creep(w, call);
        ContactBuffer out;
        e.collide(w.space(), 4, out);
        ASSERT_EQ(contact_digest(out), reference_digest(w.space())) << "call " << call;
        ASSERT_GT(out.size(), 5000u);
        const omp::CollideEngine::ListCounts c = e.list_counts();
        EXPECT_EQ(c.builds, call < 6 ? 1u : 2u) << "call " << call;
        EXPECT_EQ(c.patches, static_cast<std::size_t>(call < 6 ? call : call - 1)) << "call " << call;
        EXPECT_EQ(c.merges_sorted, 0u) << "call " << call;
    }
}

// Ghosts without ODE geoms (World::set_ghost_geoms(false), as a distributed
// run's pipeline sets it for the grid): while bodies leave, arrive as ghosts
// or owned, and turn from one to the other, the grid's contacts equal those
// of a world whose ghosts keep their geoms, which ODE's own space gives; the
// space holds no geom of a ghost, and a ghost turned owned collides again.
TEST(NeighbourList, GhostsWithoutGeomsGiveTheContactsOfGhostsWithGeoms) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=8000"});
    std::vector<std::uint32_t> gids, later;
    for (std::uint32_t i = 0; i < 8000; ++i) (i % 4 ? gids : later).push_back(static_cast<std::uint32_t>((std::uint64_t{i} * 7919) % 8000));
    World with(sc, SpaceKind::Hash, &gids), without(sc, SpaceKind::Hash, &gids);
    for (std::size_t i = 0; i < gids.size(); i += 5) with.set_ghost(i, true);
    for (std::size_t i = 0; i < gids.size(); i += 5) without.set_ghost(i, true);
    without.set_ghost_geoms(false);  // the ghosts held give theirs up at once
    omp::CollideEngine e;
    e.set_threads(2);
    e.set_geoms(without.space(), &without.geoms());
    e.set_sphere_bodies(without.sphere_bodies());
    std::size_t next = 0;
    for (int call = 0; call < 6; ++call) {
        for (World* w : {&with, &without}) {
            for (std::size_t k = 0; call > 0 && k < 40; ++k) w->remove_body((k * 131 + static_cast<std::size_t>(call)) % w->body_count());
            for (std::size_t k = 0; call > 0 && k < 60 && next + k < later.size(); ++k) w->add_body(later[next + k], k % 3 == 0);
            for (std::size_t k = 0; call > 0 && k < 30; ++k) {
                const std::size_t i = (k * 257 + static_cast<std::size_t>(call) * 11) % w->body_count();
                w->set_ghost(i, !w->ghost(i));
            }
            creep(*w, call);
        }
        next += call > 0 ? 60 : 0;
        std::size_t ghosts = 0;
        for (std::size_t i = 0; i < without.body_count(); ++i) ghosts += without.ghost(i) ? 1 : 0;
        ASSERT_GT(ghosts, 1000u);
        EXPECT_EQ(without.geomless(), ghosts) << "call " << call;
        EXPECT_EQ(static_cast<std::size_t>(dSpaceGetNumGeoms(without.space())) + ghosts, without.geoms().size()) << "call " << call;
        ContactBuffer out;
        e.collide(without.space(), 4, out);
        ASSERT_EQ(contact_digest(out), reference_digest(with.space())) << "call " << call;
        ASSERT_GT(out.size(), 5000u);
    }
    const Scene buggy = test::repo_scene("jobs/scenes/buggy.toml");
    World boxes(buggy, SpaceKind::Simple);
    EXPECT_THROW(boxes.set_ghost_geoms(false), std::logic_error);  // a box among the bodies: no sphere hint
}

// A table out of id order (as a rank's: owned bodies and ghosts in local
// order) is walked in id order: the contacts still equal ODE's, and every
// merge writes the lanes in order without sorting. 20,000 spheres on three
// threads sort their ids in two blocks and one merge round.
TEST(NeighbourList, ATableOutOfIdOrderIsWalkedInIdOrder) {
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=20000"});
    const std::uint32_t n = 20000;
    std::vector<std::uint32_t> gids(n);
    for (std::uint32_t i = 0; i < n; ++i) gids[i] = static_cast<std::uint32_t>((std::uint64_t{i} * 7919) % n);
    World w(sc, SpaceKind::Hash, &gids);
    ASSERT_NE(w.sphere_bodies(), nullptr);
    omp::CollideEngine e;
    e.set_threads(3);
    e.set_geoms(w.space(), &w.geoms());
    e.set_sphere_bodies(w.sphere_bodies());
    for (int call = 0; call < 4; ++call) {
        creep(w, call);
        ContactBuffer out;
        e.collide(w.space(), 4, out);
        ASSERT_EQ(contact_digest(out), reference_digest(w.space())) << "call " << call;
    }
    const omp::CollideEngine::ListCounts c = e.list_counts();
    EXPECT_GE(c.builds, 1u);
    EXPECT_EQ(c.merges_in_order, 4u);
    EXPECT_EQ(c.merges_sorted, 0u);
}

}  // namespace

// The build's pair search gives the same lists with AVX2 and with the scalar
// loop, build after build while the spheres creep (radii of three sizes, so
// that the reach differs from pair to pair).
TEST(NeighbourList, TheVectorSearchBuildsTheScalarSearchsLists) {
    if (!omp::avx2_search()) GTEST_SKIP() << "no AVX2 on this machine";
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=3000"});
    World w(sc, SpaceKind::Simple);
    for (std::size_t i = 0; i < w.body_count(); i += 3) dGeomSphereSetRadius(w.geoms()[i], 0.9 * dGeomSphereGetRadius(w.geoms()[i]));
    for (std::size_t i = 1; i < w.body_count(); i += 7) dGeomSphereSetRadius(w.geoms()[i], 1.05 * dGeomSphereGetRadius(w.geoms()[i]));
    ExecutionConfig with_simd, without;
    with_simd.threads = without.threads = 2;
    without.simd = false;
    const auto exec_vec = Stages::instance().execution(with_simd), exec_scalar = Stages::instance().execution(without);
    omp::CollideEngine vec(exec_vec.get()), scalar(exec_scalar.get());
    for (omp::CollideEngine* e : {&vec, &scalar}) e->set_geoms(w.space(), &w.geoms());
    std::size_t compared = 0;
    for (int call = 0; call < 16; ++call) {
        creep(w, call);
        if (call == 8) {  // body 7 lands next to body 500: the list is rebuilt
            const dReal* q = dBodyGetPosition(dGeomGetBody(w.geoms()[500]));
            dBodySetPosition(dGeomGetBody(w.geoms()[7]), q[0] + 0.95, q[1], q[2]);
        }
        ContactBuffer a, b;
        vec.collide(w.space(), 4, a);
        scalar.collide(w.space(), 4, b);
        ASSERT_EQ(vec.list_counts().builds, scalar.list_counts().builds) << "call " << call;
        ASSERT_EQ(vec.list_digest(), scalar.list_digest()) << "call " << call;
        ASSERT_EQ(contact_digest(a), contact_digest(b)) << "call " << call;
        compared += vec.list_counts().builds > 0;
    }
    EXPECT_GE(vec.list_counts().builds, 2u);
    EXPECT_GT(compared, 0u);
}

// The merge's output (the step's contacts) leaves its growth room to small
// pages (util/scratch.hpp, Room::Small): the contacts creep up step by step,
// and a fresh 2 MB page a step was the merge's largest cost at 10^6 on a VM.
TEST(ContactBuffer, TheMergeLeavesItsGrowthRoomToSmallPages) {
    if (!huge_pages_wanted() || !test::huge_pages_supported()) GTEST_SKIP() << "no huge-page advice here";
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=64000"});
    World w(sc, SpaceKind::Simple);
    omp::CollideEngine e;
    e.set_threads(2);
    e.set_geoms(w.space(), &w.geoms());
    e.set_sphere_bodies(w.sphere_bodies());
    ContactBuffer out;
    e.collide(w.space(), 4, out);
    const std::size_t bytes = out.size() * sizeof(ContactRecord);
    ASSERT_GT(bytes, 2 * kHugePage);
    const auto a = reinterpret_cast<std::uintptr_t>(out.items().data());
    EXPECT_TRUE(test::advised(a + bytes - 1)) << "the contacts themselves";
    const std::uintptr_t room = huge_page_up(a + bytes);  // the first whole page past them
    ASSERT_LE(room + kHugePage, a + out.items().capacity() * sizeof(ContactRecord));
    EXPECT_FALSE(test::advised(room)) << "growth room";
}
