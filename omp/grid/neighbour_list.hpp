// A neighbour list with a skin (a Verlet list) over the plain spheres of
// World's flat space, kept from one collision call to the next. Built in the
// uniform grid's cells (cell_grid.hpp) over a compact copy of the spheres
// (neighbour_build.cpp), it holds every pair of spheres whose reference
// centres lie within the sum of their radii plus twice the skin.
// While no sphere has moved the skin's length from its reference centre nor
// grown, every pair that can touch is on the list, so a call tests only the
// list's pairs (about three a sphere in a pile, against thirteen boxes of the
// grid's half stencil) with ODE's whole filter (enabled, closed AABB overlap,
// body, category and collide bits) and the exact touch test: the same pairs as
// the grid, hence the same contacts, bit for bit, after the canonical merge.
// The other geoms (planes, boxes, geoms outside the grid's size) are tested
// against every sphere and each other on every call, as the grid's big list.
// Reference centres are floats and radii rounded up; the build tests pairs on
// the references themselves, and widens its cells by the measured error of
// rounding the centres (a list whose error exceeds a quarter of the skin is
// declined). The lists are walked in id
// order (a rank's table, owned bodies and ghosts in local order, is sorted
// by id once a build, in tasks), so their runs reach the merge in canonical
// order.
// A table whose slots hold other geoms than at the build (a rank's, every
// step that bodies cross its boundaries or its halo; told by a sum of hashes
// of each slot's index and id) is patched when few changed
// (neighbour_patch.cpp): the geoms that stayed keep their references and
// pairs, those that left drop out, and those that came get references and
// pairs of their own; with more than an eighth changed it is built afresh.
// Trade-off: about 36 bytes a sphere kept between calls (40 on a rank, with
// the walk) and a rebuild whenever one sphere has moved the skin's length; a
// scene whose spheres all fly apart fast rebuilds every call and then falls
// back to the grid for a while.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "omp/grid/cell_grid.hpp"
#include "omp/grid/geom_info.hpp"
#include "omp/grid/grid_pairs.hpp"
#include "omp/grid/lanes.hpp"
#include "util/scratch_pool.hpp"
#include "util/split_mix.hpp"

namespace parode::omp {

constexpr std::size_t kListBlock = 2048;     // table entries per task
constexpr std::size_t kListMaxCooldown = 16;  // calls the grid runs alone at most, between builds
constexpr std::size_t kMaxOutside = 64;       // enabled geoms outside the list, tested against every sphere

// Which geom sits at which table index, as one number: a sum over the table
// of a hash of (index, id), so that blocks can add theirs in any order.
inline std::uint64_t slot_digest(std::size_t i, std::uint32_t id) {
    return SplitMix64::mix((static_cast<std::uint64_t>(i) << 32) | id);
}

// Whether a geom with these flags goes on the list: a plain, finite sphere.
inline bool listable(std::uint32_t f) { return (f & kSphere) && !(f & kAux) && (f & kFinite); }

// The radius as a float no smaller than it.
float radius_up(double r);

// An entry of a list: a walk position. Left uninitialised when the list
// grows (the build writes every entry, on its threads).
struct ListEntry {
    ListEntry() {}
    std::uint32_t w;
};

class NeighbourList {
public:
    // Whether the list built for `owner` still covers every pair of the
    // table's spheres that can touch (checked in tasks). Counts the use.
    bool covers(const void* owner, const GeomTable& infos);
    // Whether a failed check should be followed by a build: after lists that
    // served fewer than two calls beyond their build, the grid runs alone for
    // 1, 2, 4 ... 16 calls before the next.
    bool due();
    // Builds the list of `infos` for `owner` through `grid` (whose contents it
    // overwrites). False when the table does not suit (too many geoms other
    // than plain spheres, or coordinates too large for float references): the
    // list is then empty and covers nothing.
    bool build(const void* owner, const GeomTable& infos, CellGrid& grid);
    // Whether the build's pair search may use SIMD (the same lists either way).
    void set_simd(bool on) { simd_ = on; }
    // Where a patch takes its working arrays (a slot the list path leaves
    // free: util/scratch_pool.hpp); else a pool of its own.
    void set_scratch(ScratchPool* pool) { pool_ = pool ? pool : &own_pool_; }
    // The enabled geoms outside the list, by table index.
    void others(const GeomTable& infos, std::vector<std::uint32_t>& out) const;
    // The table's entries in blocks of consecutive indices, one task each.
    std::size_t blocks() const;
    // The list's pairs and each sphere against the big entries of `in`, in
    // tasks, block b into lane[b] (runs as the grid's narrowphase writes
    // them), so that the runs arrive in canonical order.
    void pairs(const PairInputs& in, Lane* lane) const;

    struct Counts {
        std::size_t builds = 0, uses = 0, declined = 0;
        std::size_t patches = 0;  // uses that patched the list first
    };
    const Counts& counts() const { return counts_; }
    // A hash of the lists (their starts and entries): equal lists, equal hashes.
    std::uint64_t digest() const;

private:
    // What the build's first pass learns of a block of the table.
    struct Part {
        std::size_t listed = 0, outside = 0, enabled_outside = 0;
        double rmax = 0, shift = 0;
        CellBounds bounds;
        bool in_id_order = true;  // ids rise along the block
        std::uint32_t first_id = 0, last_id = 0;
        std::uint64_t slots = 0;  // slot_digest summed over the block
    };
    // What the check learns of a block: whether its spheres are still covered,
    // and its slot_digest sum.
    struct Check {
        bool ok = true;
        std::uint64_t slots = 0;
    };
    Check check_block(const GeomInfo* info, std::size_t i0, std::size_t i1) const;
    void decline();
    Part reference(const GeomView& t, std::size_t i0, std::size_t i1);
    void list_members(const std::vector<Part>& parts, std::vector<std::uint32_t>& items);
    std::vector<std::uint32_t> walk_in_id_order(const GeomView& t, bool in_order);
    void link(const CellGrid& grid, const std::vector<std::uint32_t>& items, const std::uint32_t* pos, float need);
    // neighbour_patch.cpp: the list made to cover a table whose slots changed
    // (false: too many changed, or a geom that stayed moved the skin's length;
    // the list is then as it was).
    bool patch(const GeomTable& infos);
    bool patched(const GeomTable& infos);
    struct Patch;
    // The table index at walk position w (walk_ empty: the table is in id order).
    std::uint32_t walked_slot(std::size_t w) const { return walk_.empty() ? static_cast<std::uint32_t>(w) : walk_[w]; }
    bool new_walk(Patch& p, const std::vector<std::pair<std::uint32_t, std::uint32_t>>& arrivals, std::size_t m) const;
    bool new_references(Patch& p, const GeomView& t, std::size_t m);
    std::vector<std::uint64_t> arrival_pairs(const Patch& p, std::size_t m) const;
    bool link_arrivals(Patch& p, std::size_t m);
    void commit(const Patch& p, std::size_t m);

    const void* owner_ = nullptr;
    bool simd_ = true;
    std::size_t n_ = 0;
    double skin_ = 0;
    std::vector<float> ref_;               // x, y, z, radius (rounded up) per table index; radius < 0: not listed
    // The walk: table entries in id order (empty: the table is in id order).
    // The list of the entry at walk position w: next_[start_[w] .. start_[w + 1]),
    // the walk positions after w it may touch, in increasing order.
    std::vector<std::uint32_t> walk_, start_;
    std::vector<ListEntry> next_;
    std::vector<std::uint32_t> outside_;   // table indices not listed
    std::vector<std::uint32_t> ids_;       // the geom id at each table index
    double rmax_ = 0;                      // the largest listed radius at the build
    ScratchPool own_pool_;
    ScratchPool* pool_ = &own_pool_;
    std::uint64_t slots_ = 0;              // the table's slot_digest sum at the build
    std::size_t lived_ = 0;                // calls the current list served
    std::size_t wait_ = 0, cooldown_ = 0;  // calls to skip before the next build
    Counts counts_;
};

}  // namespace parode::omp
