// The OpenMP collision engine and its "grid" backend: a uniform-grid broadphase
// over compact, spatially sorted copies of the geoms' AABBs (rebuilt every call,
// memory linear in the number of geoms), oversized and infinite geoms kept in a
// separate list tested against everything, and a narrowphase of dCollide calls
// run as OpenMP tasks that each append to their thread's buffer, merged at the
// end into canonical contact order.
//
// It reports exactly the pairs ODE's own spaces hand to a near-callback (same
// filtering as ODE's collideAABBs: enabled and non-zero-sized geoms, same-body
// pairs skipped, category/collide bits, closed AABB overlap; geoms of disabled
// bodies are collided, as ODE does), recursing into nested spaces as
// collide_space_reference does, so its contacts equal the reference bit for bit.
// Pairs involving trimeshes, heightfields, convexes, geom transforms or nested
// spaces are deferred and run serially; a space holding a user-defined geom
// class (whose AABB test the public API cannot call) is handed to ODE whole.
// One corner of ODE is order-dependent and not reproduced: two sibling nested
// spaces with equal geom counts and equal sublevels meet through the geoms of
// whichever one ODE's traversal names second, and those geoms are not checked
// for being enabled; the results differ only if that space holds disabled or
// zero-sized geoms (give the spaces different sublevels to avoid it).
//
// For the flat space of World (set_geoms, set_sphere_bodies) the grid's sphere
// pairs are kept between calls as a neighbour list with a skin
// (neighbour_list.hpp), checked every call and rebuilt through the grid when a
// sphere has moved the skin's length: the same pairs, so the same contacts.
//
// Trade-off: one more copy of every AABB per call (cheap, sequential) buys a
// broadphase that touches ODE's scattered geom memory once per geom and runs
// at any size: no n^2 bit matrix as in ODE's hash space.
#pragma once
#include <ode/ode.h>

#include <memory>
#include <string>

#include "collide/collide.hpp"
#include "collide/contacts.hpp"
#include "exec/execution.hpp"

namespace parode::omp {

// Reusable collision engine. Not thread-safe itself: one engine per calling
// thread (it starts its own OpenMP team). Buffers are kept between calls.
class CollideEngine {
public:
    // Threads, crossovers, scratch pool and SIMD from `exec`, which must
    // outlive the engine; null: an execution of its own on OpenMP's default
    // threads (set_threads changes it).
    explicit CollideEngine(Execution* exec = nullptr);
    // An engine with an execution of its own, of `config`.
    explicit CollideEngine(const ExecutionConfig& config);
    ~CollideEngine();
    CollideEngine(const CollideEngine&) = delete;
    CollideEngine& operator=(const CollideEngine&) = delete;

    // An engine with its own execution: its threads (<= 0: OpenMP's default).
    // Throws std::logic_error on an engine given an execution.
    void set_threads(int threads);
    // `space` holds exactly `geoms` and no nested space: read them in parallel
    // instead of walking ODE's list (nullptr forgets the hint).
    void set_geoms(dSpaceID space, const std::vector<dGeomID>* geoms);
    // With set_geoms: what is known of its first geoms (collide.hpp), or null.
    void set_sphere_bodies(const SphereBodies* spheres);
    int threads() const;

    // Every contact of `space`, recursing into nested spaces; equals
    // collide_space_reference(space, ...). `out` is overwritten.
    void collide(dSpaceID space, int max_contacts, ContactBuffer& out);
    // collide() leaves out the contacts `test` drops (null: none); the pairs
    // are found and tested as before, only their runs are not merged.
    void set_ghost_test(const GhostTest* test);

    // `geom` (a geom or a space) against `space`; equals
    // collide2_reference(geom, space, ...). `out` is overwritten.
    void collide2(dGeomID geom, dSpaceID space, int max_contacts, ContactBuffer& out);

    // Wall seconds of the phases of the last call (summed over nested spaces).
    struct PhaseTimes {
        double read = 0;      // listing and reading geoms
        double build = 0;     // small/big split and grid build
        double pairs = 0;     // broadphase + narrowphase tasks
        double deferred = 0;  // serial pairs (nested spaces, unsafe classes)
        double merge = 0;     // canonical merge
        // The pair tasks' wall time split by the threads' time in each part.
        double broad = 0, narrow = 0;
    };
    const PhaseTimes& last_phase_times() const;

    // The flat space's neighbour list (neighbour_list.hpp): on by default;
    // off, every call runs the grid. Results are the same either way.
    void set_neighbour_list(bool on);
    bool neighbour_list() const;
    struct ListCounts {
        std::size_t builds = 0, uses = 0, declined = 0;
        std::size_t patches = 0;  // uses that patched the list for a changed table first
        // collide()'s merges whose lanes arrived in canonical order, and the others.
        std::size_t merges_in_order = 0, merges_sorted = 0;
    };
    ListCounts list_counts() const;
    // NeighbourList::digest of the current list (for tests).
    std::uint64_t list_digest() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

// The "grid" backend: CollideEngine behind the CollideBackend interface. Cheap to
// construct. It accepts any ODE space; it asks World for a simple space, whose
// bookkeeping is the cheapest since it only serves as a container.
// "grid-nolist" is the same without the neighbour list (every call runs the
// grid): the reference the list is measured against.
class GridBackend final : public CollideBackend {
public:
    explicit GridBackend(Execution& exec, bool neighbour_list = true) : engine_(&exec) {
        engine_.set_neighbour_list(neighbour_list);
    }
    std::string name() const override { return engine_.neighbour_list() ? "grid" : "grid-nolist"; }
    SpaceKind space_kind() const override { return SpaceKind::Simple; }
    void collide(dSpaceID space, int max_contacts, ContactBuffer& out) override;
    void set_geoms(dSpaceID space, const std::vector<dGeomID>* geoms) override { engine_.set_geoms(space, geoms); }
    void set_sphere_bodies(const SphereBodies* spheres) override { engine_.set_sphere_bodies(spheres); }
    bool reads_sphere_poses() const override { return true; }  // read_geom (geom_info.hpp)
    bool spheres_from_hint() const override { return true; }   // read_geoms, hinted_sphere
    bool set_ghost_test(const GhostTest* test) override {
        engine_.set_ghost_test(test);
        return true;
    }
    const CollideEngine& engine() const { return engine_; }
    // refresh (reading the geoms), broadphase (split, grid, candidates),
    // narrowphase (exact tests, dCollide, deferred pairs), merge.
    const Substages* substages() const override { return &times_; }
    // The neighbour list's builds, the calls it served without a build, and
    // the calls it declined (a space of many other geoms); the merges whose
    // lanes arrived in canonical order, and those that sorted.
    std::vector<std::pair<std::string, std::int64_t>> counts() const override;

private:
    CollideEngine engine_;
    Substages times_;
};

}  // namespace parode::omp
