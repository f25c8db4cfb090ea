// The OpenMP collision engine against ODE's own dSpaceCollide/dSpaceCollide2
// (collide_space_reference / collide2_reference on a hash space): same pairs,
// same contacts, bit for bit, for 1 to 4 threads, on seeded random scenes with
// every filter case, on the sphere prism, on a sparse scene, and through the
// library entry points and the registry. The sphere fast paths are checked
// against dCollide directly.
// Trade-off: scenes are small (hundreds of geoms) to keep the suite fast; the
// prism test adds a few thousand spheres for the grid's dense path.
#include <gtest/gtest.h>
#include <ode/ode.h>

#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "omp/grid/grid_boxes.hpp"
#include "omp/grid/cell_grid.hpp"
#include "collide/collide.hpp"
#include "collide_bench.hpp"
#include "collide/contacts.hpp"
#include "omp/grid/fast_pairs.hpp"
#include "omp/grid/grid_collide.hpp"
#include "omp/grid/parallel_collide.hpp"
#include "random_scene.hpp"
#include "omp/stages.hpp"

namespace parode::test {
namespace {

// An engine's execution on `threads` threads with its threaded paths at every
// size (min_parallel 0: the results are the same, only the cost differs).
ExecutionConfig threaded(int threads) {
    ExecutionConfig c;
    c.threads = threads > 0 ? threads : omp::default_threads();
    c.min_parallel = 0;
    return c;
}

constexpr int kMaxContacts = 8;

bool same_bits(const dReal* a, const dReal* b, int n) {
    return std::memcmp(a, b, sizeof(dReal) * static_cast<std::size_t>(n)) == 0;
}

// Every field of every contact, bitwise, plus the digest.
void expect_identical(const ContactBuffer& ref, const ContactBuffer& got, const char* what) {
    ASSERT_EQ(ref.size(), got.size()) << what;
    EXPECT_EQ(contact_digest(ref), contact_digest(got)) << what;
    for (std::size_t i = 0; i < ref.size(); ++i) {
        const ContactRecord& a = ref.items()[i];
        const ContactRecord& b = got.items()[i];
        ASSERT_EQ(a.lo, b.lo) << what << " contact " << i;
        ASSERT_EQ(a.hi, b.hi) << what << " contact " << i;
        ASSERT_TRUE(same_bits(a.geom.pos, b.geom.pos, 3)) << what << " contact " << i;
        ASSERT_TRUE(same_bits(a.geom.normal, b.geom.normal, 3)) << what << " contact " << i;
        ASSERT_TRUE(same_bits(&a.geom.depth, &b.geom.depth, 1)) << what << " contact " << i;
        ASSERT_EQ(ref.sides(i).side1, got.sides(i).side1) << what << " contact " << i;
        ASSERT_EQ(ref.sides(i).side2, got.sides(i).side2) << what << " contact " << i;
    }
}

void expect_engine_matches(dSpaceID space, const char* what) {
    ContactBuffer ref;
    collide_space_reference(space, kMaxContacts, ref);
    ASSERT_GT(ref.size(), 0u) << what << ": scene has no contacts, test would be vacuous";
    for (int t = 1; t <= 4; ++t) {
        omp::CollideEngine engine(threaded(t));
        ContactBuffer got;
        engine.collide(space, kMaxContacts, got);
        SCOPED_TRACE(testing::Message() << what << ", threads " << t);
        expect_identical(ref, got, what);
    }
}

class RandomScenes : public testing::TestWithParam<std::uint32_t> {};

// The trimesh sheet's contacts name a triangle (ODE's sides): over a few
// seeds some do, and the engine keeps each with its contact, through the
// merge of the lanes, on every thread count.
TEST(ContactSides, TrimeshSidesSurviveTheMerge) {
    std::size_t with_sides = 0;
    for (std::uint32_t seed = 1; seed <= 12; ++seed) {
        RandomScene scene(seed, SceneOptions{});
        ContactBuffer ref;
        collide_space_reference(scene.space(), kMaxContacts, ref);
        for (std::size_t k = 0; k < ref.size(); ++k) with_sides += !ref.sides(k).none();
        expect_engine_matches(scene.space(), "trimesh sides");
    }
    EXPECT_GT(with_sides, 0u);
}

TEST_P(RandomScenes, CollideMatchesOdeHashSpace) {
    RandomScene scene(GetParam(), SceneOptions{});
    expect_engine_matches(scene.space(), "random scene");
}

TEST_P(RandomScenes, CollideWithoutSpecialsMatches) {
    SceneOptions opt;
    opt.special = false;
    opt.nested = 0;
    opt.geoms = 500;
    RandomScene scene(GetParam() + 100, opt);
    expect_engine_matches(scene.space(), "plain random scene");
}

TEST_P(RandomScenes, Collide2OfEachGeomMatches) {
    SceneOptions opt;
    opt.geoms = 150;
    RandomScene scene(GetParam() + 200, opt);
    const std::vector<dGeomID>& geoms = scene.geoms();
    std::size_t touching = 0;
    for (std::size_t i = 0; i < geoms.size(); i += 7) {
        ContactBuffer ref;
        collide2_reference(geoms[i], scene.space(), kMaxContacts, ref);
        touching += ref.size();
        for (int t = 1; t <= 4; ++t) {
            omp::CollideEngine engine(threaded(t));
            ContactBuffer got;
            engine.collide2(geoms[i], scene.space(), kMaxContacts, got);
            SCOPED_TRACE(testing::Message() << "geom " << i << ", threads " << t);
            expect_identical(ref, got, "collide2 geom");
        }
    }
    EXPECT_GT(touching, 0u);
}

TEST_P(RandomScenes, Collide2OfSpaceMatches) {
    RandomScene scene(GetParam() + 300, SceneOptions{});
    ASSERT_NE(scene.nested(), nullptr);
    // A small space against the big one, and the reverse argument order.
    ContactBuffer ref, ref_rev;
    collide2_reference(reinterpret_cast<dGeomID>(scene.nested()), scene.space(), kMaxContacts, ref);
    collide2_reference(reinterpret_cast<dGeomID>(scene.space()), scene.nested(), kMaxContacts, ref_rev);
    ASSERT_GT(ref.size(), 0u);
    for (int t = 1; t <= 4; ++t) {
        omp::CollideEngine engine(threaded(t));
        ContactBuffer got;
        engine.collide2(reinterpret_cast<dGeomID>(scene.nested()), scene.space(), kMaxContacts, got);
        expect_identical(ref, got, "collide2 nested->top");
        engine.collide2(reinterpret_cast<dGeomID>(scene.space()), scene.nested(), kMaxContacts, got);
        expect_identical(ref_rev, got, "collide2 top->nested");
    }
}

INSTANTIATE_TEST_SUITE_P(Seeds, RandomScenes, testing::Values(1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u));

TEST(GridCollide, SpherePrismMatches) {
    SpherePrism prism(12, 0.5, 0.01, 42, dHashSpaceClass);
    expect_engine_matches(prism.space(), "sphere prism");
}

TEST(GridCollide, ExactlyTouchingLatticeMatches) {
    // No jitter: neighbouring AABBs share faces exactly and spheres touch at
    // depth 0; ODE's closed overlap test reports these pairs.
    SpherePrism prism(8, 0.5, 0.0, 1, dHashSpaceClass);
    expect_engine_matches(prism.space(), "touching lattice");
    dSpaceID boxes = dHashSpaceCreate(nullptr);
    std::uint32_t id = 0;
    for (int i = 0; i < 6; ++i) {
        for (int j = 0; j < 6; ++j) {
            for (int k = 0; k < 3; ++k) {
                dGeomID g = dCreateBox(boxes, 1, 1, 1);
                dGeomSetPosition(g, i, j, k);
                set_geom_id(g, id++);
            }
        }
    }
    expect_engine_matches(boxes, "touching boxes");
    dSpaceDestroy(boxes);
}

// Two sibling nested spaces of touching spheres that overlap each other: the
// pair of spaces is collided after both spaces' own sphere pairs were found,
// and reads the geoms of one of them again (the contacts found before must
// not change when it does).
TEST(GridCollide, SiblingSpacesOfSpheresMatch) {
    dSpaceID top = dSimpleSpaceCreate(nullptr);
    dSpaceID first = dSimpleSpaceCreate(top);
    dSpaceID second = dSimpleSpaceCreate(top);
    dSpaceSetCleanup(first, 0);
    dSpaceSetCleanup(second, 0);
    std::vector<dGeomID> made;
    std::uint32_t id = 0;
    auto row = [&](dSpaceID space, int n, double y) {
        for (int i = 0; i < n; ++i) {
            dGeomID g = dCreateSphere(space, 0.5);
            dGeomSetPosition(g, 0.9 * i, y, 0);
            set_geom_id(g, id++);
            made.push_back(g);
        }
    };
    row(second, 30, 0.0);
    row(first, 12, 0.8);
    set_geom_id(reinterpret_cast<dGeomID>(first), id++);
    set_geom_id(reinterpret_cast<dGeomID>(second), id++);
    expect_engine_matches(top, "sibling spaces of spheres");
    for (dGeomID g : made) dGeomDestroy(g);
    dSpaceDestroy(first);
    dSpaceDestroy(second);
    dSpaceDestroy(top);
}

TEST(GridCollide, SparseScatterMatches) {
    // Few geoms over a huge region: the grid takes its sparse (sorted-key) path.
    SceneOptions opt;
    opt.geoms = 400;
    opt.extent = 2000;
    opt.special = false;
    opt.nested = 0;
    RandomScene scene(11, opt);
    ContactBuffer ref;
    collide_space_reference(scene.space(), kMaxContacts, ref);
    for (int t = 1; t <= 4; ++t) {
        omp::CollideEngine engine(threaded(t));
        ContactBuffer got;
        engine.collide(scene.space(), kMaxContacts, got);
        expect_identical(ref, got, "sparse scatter");
    }
}

TEST(GridCollide, RepeatedCallsAndMovedGeomsMatch) {
    RandomScene scene(21, SceneOptions{});
    omp::CollideEngine engine(threaded(3));
    for (int step = 0; step < 3; ++step) {
        for (std::size_t i = 0; i < scene.geoms().size(); i += 5) {
            dGeomID g = scene.geoms()[i];
            if (dGeomGetClass(g) == dPlaneClass) continue;
            const dReal* p = dGeomGetPosition(g);
            dBodyID b = dGeomGetBody(g);
            if (b) {
                dBodySetPosition(b, p[0] + 0.1, p[1] - 0.05, p[2]);
            } else {
                dGeomSetPosition(g, p[0] + 0.1, p[1] - 0.05, p[2]);
            }
        }
        ContactBuffer ref, got;
        collide_space_reference(scene.space(), kMaxContacts, ref);
        engine.collide(scene.space(), kMaxContacts, got);
        expect_identical(ref, got, "after moving geoms");
    }
}

TEST(GridCollide, MaxContactsIsRespected) {
    RandomScene scene(31, SceneOptions{});
    for (int max : {1, 2, 4}) {
        ContactBuffer ref, got;
        collide_space_reference(scene.space(), max, ref);
        collide(scene.space(), max, got, 2);
        expect_identical(ref, got, "max contacts");
    }
}

// The broadphase's span test over grid boxes: every run [b0, b1) of every
// geom, the passing candidates exactly those of ODE's closed overlap test
// (aabb_overlap on the AABBs the boxes were made from), in order, for the
// scalar loop and the SSE2 one. Bounds are drawn from a few values so that
// touching boxes (equal bounds) are common, with some NaN among them.
TEST(GridBoxes, SpanTestsPassExactlyTheOverlappingBoxes) {
    constexpr std::size_t kGeoms = 64;
    std::mt19937 rng(7);
    const double values[] = {0.0, 1.0, 2.0, 3.0, std::nan("")};
    std::uniform_int_distribution<int> pick(0, 19);  // NaN one time in 20
    std::vector<std::array<double, 6>> aabbs(kGeoms);
    std::vector<omp::GridBox> boxes(kGeoms);
    for (std::size_t g = 0; g < kGeoms; ++g) {
        for (std::size_t k = 0; k < 3; ++k) {
            const int lo = pick(rng) % 4, span = pick(rng);
            aabbs[g][2 * k] = span == 19 ? values[4] : values[lo];
            aabbs[g][2 * k + 1] = values[std::min(3, lo + span % 3)];
        }
        omp::box_from_aabb(aabbs[g].data(), boxes[g].key);
    }
    std::size_t passing = 0;
    std::vector<omp::Candidate> got(kGeoms + 1);
    for (std::size_t a = 0; a < kGeoms; ++a) {
        for (std::uint32_t b0 = 0; b0 <= kGeoms; b0 += 3) {
            for (std::uint32_t b1 = b0; b1 <= kGeoms; b1 += 5) {
                std::vector<std::uint32_t> want;
                for (std::uint32_t b = b0; b < b1; ++b) {
                    if (omp::aabb_overlap(aabbs[a].data(), aabbs[b].data())) want.push_back(b);
                }
                passing += want.size();
                const std::size_t n = omp::overlap_span_scalar(boxes.data(), a, b0, b1, got.data(), 0);
                ASSERT_EQ(n, want.size()) << "scalar, a " << a << " [" << b0 << ", " << b1 << ")";
                for (std::size_t j = 0; j < n; ++j) ASSERT_EQ(got[j].b, want[j]);
#if defined(__SSE2__)
                const std::size_t m = omp::overlap_span_sse2(boxes.data(), a, b0, b1, got.data(), 0);
                ASSERT_EQ(m, want.size()) << "SSE2, a " << a << " [" << b0 << ", " << b1 << ")";
                for (std::size_t j = 0; j < m; ++j) {
                    ASSERT_EQ(got[j].a, a);
                    ASSERT_EQ(got[j].b, want[j]);
                }
#endif
            }
        }
    }
    EXPECT_GT(passing, 1000u);  // not vacuous: many boxes overlap, many touch
}

TEST(FastPairs, SphereSphereAndSpherePlaneEqualDCollide) {
    dSpaceID space = dSimpleSpaceCreate(nullptr);
    std::vector<dGeomID> spheres;
    std::uint64_t s = 5;
    auto rnd = [&s] {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        return static_cast<double>(s >> 11) / 9007199254740992.0;
    };
    for (int i = 0; i < 400; ++i) {
        dGeomID g = dCreateSphere(space, 0.3 + 0.4 * rnd());
        dGeomSetPosition(g, 3 * rnd(), 3 * rnd(), 3 * rnd());
        set_geom_id(g, static_cast<std::uint32_t>(i));
        spheres.push_back(g);
    }
    dGeomSetPosition(spheres[1], 0, 0, 0);  // coincident centres: ODE's d <= 0 branch
    dGeomSetPosition(spheres[2], 0, 0, 0);
    dGeomID plane_lo = dCreatePlane(space, 0.2, 0.3, 0.9, 0.7);  // normalised by ODE
    dGeomID plane_hi = dCreatePlane(space, 0, 0, 1, 1.2);
    set_geom_id(plane_lo, 0);  // lower id than every sphere but sphere 0: reversed call
    set_geom_id(spheres[0], 1000);
    set_geom_id(plane_hi, 5000);
    std::vector<omp::PrimData> prim;
    auto data = [](dGeomID g) {
        omp::PrimData p{g, geom_id(g), 0, {0, 0, 0, 0}};
        if (dGeomGetClass(g) == dSphereClass) {
            const dReal* pos = dGeomGetPosition(g);
            for (int k = 0; k < 3; ++k) p.p[k] = pos[k];
            p.p[3] = dGeomSphereGetRadius(g);
        } else {
            dGeomPlaneGetParams(g, p.p);
        }
        return p;
    };
    std::vector<dGeomID> all = spheres;
    all.push_back(plane_lo);
    all.push_back(plane_hi);
    std::size_t compared = 0;
    for (std::size_t i = 0; i < all.size(); ++i) {
        for (std::size_t j = i + 1; j < all.size(); ++j) {
            const bool si = dGeomGetClass(all[i]) == dSphereClass;
            const bool sj = dGeomGetClass(all[j]) == dSphereClass;
            if (!si && !sj) continue;
            ContactBuffer ref, got;
            ref.collide_pair(all[i], all[j], 4);
            omp::append_fast_pair(data(all[i]), si, data(all[j]), sj, 4, got);
            expect_identical(ref, got, "fast pair");
            compared += ref.size();
        }
    }
    EXPECT_GT(compared, 100u);
    dSpaceDestroy(space);
}

// fast_touch (the grid's test) says "touch" exactly when fast_contact gives
// a contact, both ways round, and spheres_overlap_and_touch (the list's)
// exactly when ODE's sphere AABBs overlap too, for pairs at the edge of
// touching: the distance swept ulp by ulp and by relative steps of 1e-11
// around the sum of the radii, over magnitudes from where the squares fall
// below the normal range to where they overflow, near the origin and far
// from it (where rounding x -+ r can part the AABBs of touching spheres),
// with negative radii and NaN centres too.
TEST(FastPairs, TouchTestsAgreeWithTheContactAtTheEdge) {
    auto sphere = [](double x, double y, double off, double r, std::uint32_t id) {
        omp::PrimData p{nullptr, id, 0, {off + x, off + y, off + 0.5 * y, r}};
        p.geom = reinterpret_cast<dGeomID>(static_cast<std::uintptr_t>(16 + id));  // distinct, never read
        return p;
    };
    std::size_t pairs = 0, touching = 0, parted = 0;
    int mismatches = 0;
    auto check = [&](const omp::PrimData& a, const omp::PrimData& b) {
        ContactRecord c;
        const bool contact = omp::fast_contact(a, true, b, true, 4, c);
        dReal ba[6], bb[6];
        omp::sphere_aabb(a.p, ba);
        omp::sphere_aabb(b.p, bb);
        const bool overlap = omp::aabb_overlap(ba, bb);
        for (const bool swapped : {false, true}) {
            const omp::PrimData& p = swapped ? b : a;
            const omp::PrimData& q = swapped ? a : b;
            const bool touch = omp::fast_touch(p, true, q, true);
            const bool listed = omp::spheres_overlap_and_touch(p, q);
            if ((touch != contact || listed != (overlap && contact)) && ++mismatches <= 5) {
                ADD_FAILURE() << "radii " << a.p[3] << ", " << b.p[3] << " at " << b.p[0] << " - " << a.p[0]
                              << ": touch " << touch << ", contact " << contact << ", listed " << listed
                              << ", overlap " << overlap;
            }
        }
        ++pairs;
        touching += contact;
        parted += contact && !overlap;
    };
    for (double scale = 1e-170; scale < 1e170; scale *= 7.3) {
        const double r1 = 0.5 * scale, r2 = 0.3 * scale, sum = r1 + r2;
        for (const double off : {0.0, 3e7 * scale}) {
            const omp::PrimData a = sphere(0, 0, off, r1, 0);
            for (const double y : {0.0, 0.1 * scale}) {
                const double along = std::sqrt(std::max(0.0, sum * sum - 1.25 * y * y));
                double x = along;
                for (int k = 0; k < 40; ++k) x = std::nextafter(x, 0.0);
                for (int k = 0; k < 80; ++k, x = std::nextafter(x, HUGE_VAL)) check(a, sphere(x, y, off, r2, 1));
                for (double rel = -1e-9; rel <= 1e-9; rel += 1e-11) check(a, sphere(along * (1 + rel), y, off, r2, 1));
            }
        }
    }
    check(sphere(0, 0, 0, -0.5, 0), sphere(0.1, 0, 0, 0.3, 1));             // negative radii: never touch
    check(sphere(0, 0, 0, 0.5, 0), sphere(std::nan(""), 0, 0, 0.3, 1));     // NaN: never touch
    check(sphere(0, 0, 0, 1e200, 0), sphere(1e200, 1e200, 0, 1e200, 1));  // squares overflow
    EXPECT_EQ(mismatches, 0);
    EXPECT_GT(touching, pairs / 4);      // not vacuous: both outcomes,
    EXPECT_LT(touching, 3 * pairs / 4);  // in about equal numbers,
    EXPECT_GT(parted, 0u);               // and touching spheres whose AABBs part
}

// What the callback saw: the pairs as records, and whether every contact
// named the two geoms the callback was given.
struct Seen {
    ContactBuffer buf;
    bool geoms_match = true;
};

TEST(LibraryApi, CallbackSeesCanonicalPairs) {
    RandomScene scene(41, SceneOptions{});
    ContactBuffer ref;
    collide_space_reference(scene.space(), kMaxContacts, ref);
    auto cb = [](void* data, dGeomID g1, dGeomID g2, const dContactGeom* c, int n) {
        auto* out = static_cast<Seen*>(data);
        for (int k = 0; k < n; ++k) {
            out->buf.push(ContactRecord(geom_id(g1), geom_id(g2), c[k]), ContactSides{c[k].side1, c[k].side2});
            out->geoms_match = out->geoms_match && c[k].g1 == g1 && c[k].g2 == g2;
        }
    };
    Seen seen;
    collide_space(scene.space(), kMaxContacts, &seen, cb, 2);
    expect_identical(ref, seen.buf, "callback");
    EXPECT_TRUE(seen.geoms_match);
    ContactBuffer ref2;
    Seen seen2;
    collide2_reference(scene.geoms()[3], scene.space(), kMaxContacts, ref2);
    collide_space2(scene.geoms()[3], scene.space(), kMaxContacts, &seen2, cb, 2);
    expect_identical(ref2, seen2.buf, "callback collide2");
    EXPECT_TRUE(seen2.geoms_match);
}

// A pair callback over contacts whose geoms the lookup lacks stops with a
// message naming the id, before any callback runs.
TEST(LibraryApi, ForEachPairNamesAMissingGeom) {
    RandomScene scene(41, SceneOptions{});
    ContactBuffer buf;
    collide(scene.space(), kMaxContacts, buf, 2);
    ASSERT_GT(buf.size(), 0u);
    GeomsById geoms;  // empty
    int calls = 0;
    auto cb = [](void* data, dGeomID, dGeomID, const dContactGeom*, int) { ++*static_cast<int*>(data); };
    try {
        for_each_pair(buf, geoms, &calls, cb);
        FAIL() << "no error for an empty lookup";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("no geom with id " + std::to_string(buf.items()[0].lo)), std::string::npos)
            << e.what();
    }
    EXPECT_EQ(calls, 0);
}

TEST(LibraryApi, RegistryGridBackendMatches) {
    omp::add_stages();
    const auto exec = Stages::instance().execution(threaded(2));
    auto grid = Stages::instance().collide.make("grid", *exec);
    EXPECT_EQ(grid->name(), "grid");
    EXPECT_EQ(Stages::instance().collide.canonical("grid/omp"), "grid");
    RandomScene scene(51, SceneOptions{});
    ContactBuffer ref, got;
    collide_space_reference(scene.space(), kMaxContacts, ref);
    grid->collide(scene.space(), kMaxContacts, got);
    expect_identical(ref, got, "registry grid");
}

TEST(LibraryApi, BenchReportsReferenceDigest) {
    omp::add_stages();
    SpherePrism prism(6, 0.5, 0.01, 3, dHashSpaceClass);
    ContactBuffer ref;
    collide_space_reference(prism.space(), kMaxContacts, ref);
    const auto results =
        omp::bench_collide(prism.space(), {"ode-hash", "ode-sap", "grid"}, {1, 2}, kMaxContacts, 3);
    ASSERT_EQ(results.size(), 4u);
    for (const auto& r : results) {
        EXPECT_EQ(r.contacts, ref.size()) << r.backend;
        EXPECT_EQ(r.digest, contact_digest(ref)) << r.backend << " threads " << r.threads;
        EXPECT_GT(r.median_s, 0.0);
    }
    ContactBuffer after;
    collide_space_reference(prism.space(), kMaxContacts, after);  // geoms are back home
    EXPECT_EQ(contact_digest(after), contact_digest(ref));
    EXPECT_EQ(dSpaceGetClass(prism.space()), dHashSpaceClass);
}

}  // namespace
}  // namespace parode::test

int main(int argc, char** argv) {
    dInitODE2(0);
    dAllocateODEDataForThread(dAllocateMaskAll);
    testing::InitGoogleTest(&argc, argv);
    const int rc = RUN_ALL_TESTS();
    dCloseODE();
    return rc;
}
