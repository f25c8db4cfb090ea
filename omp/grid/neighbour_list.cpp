// The neighbour list of neighbour_list.hpp in use: the check that it still
// covers the spheres, and the pass over its pairs (the build is in
// neighbour_build.cpp).
// Trade-off: the pass writes a run for every listed pair and keeps it only if
// the pair touches, so a list a few times longer than the contacts costs
// writes, never a branch on a near-random outcome.
#include "omp/grid/neighbour_list.hpp"
#include "omp/runtime/task_split.hpp"
#include "util/hash.hpp"
#include "util/substages.hpp"

#include <algorithm>

namespace parode::omp {
namespace {

// A pair of a listed sphere and a big entry that is not a fast pair.
struct BigPair {
    const PrimData* a;
    std::uint32_t big;
};

// Geom a (listed, enabled) against the big entries: as the grid's
// narrowphase treats a big-list candidate that passed the whole filter. Fast
// pairs that touch are written at out[n] (n advanced); the others are set
// aside in `slow`.
std::size_t against_big(const PairInputs& in, const GridEntry& ea, const PrimData& pa, PairRun* out, std::size_t n,
                        std::vector<BigPair>& slow) {
    const std::uint32_t fa = ea.tag.flags;
    for (std::size_t j = 0; j < in.nbig; ++j) {
        if (!passes(in, ea, in.big[j])) continue;
        const PrimData& pb = in.big_prims[j];
        const std::uint32_t fb = in.big[j].tag.flags;
        if (!fast_pair(fa, fb)) {
            slow.push_back(BigPair{&pa, static_cast<std::uint32_t>(j)});
            continue;
        }
        const bool touch =
            (in.max_contacts >= 1) & (pa.geom != pb.geom) & fast_touch(pa, true, pb, (fb & kSphere) != 0);
        out[n] = PairRun(std::min(pa.id, pb.id), std::max(pa.id, pb.id), ea.tag.info,
                         static_cast<std::uint32_t>(j) | kBigList);
        n += touch;
    }
    return n;
}

// The table entry at walk position w (walk null: the table is in id order).
std::uint32_t walked(const std::uint32_t* walk, std::size_t w) { return walk ? walk[w] : static_cast<std::uint32_t>(w); }

// The listed pairs of a sphere at out[n]; returns the new n.
std::size_t list_sphere(const PairInputs& in, const GridEntry& ea, const PrimData& pa, const ListEntry* next,
                        const std::uint32_t* walk, std::uint32_t k0, std::uint32_t k1, PairRun* out, std::size_t n) {
    const GeomInfo* info = in.infos.info;
    for (std::uint32_t k = k0; k < k1; ++k) {
        const std::uint32_t b = walked(walk, next[k].w);
        const GeomInfo& gb = info[b];
        const GridTag tb{gb.body, b, gb.prim.flags};
        const bool touch = ((gb.prim.flags & kEnabled) != 0) & tags_pass(in, ea.tag, tb) & (in.max_contacts >= 1) &
                           spheres_overlap_and_touch(pa, gb.prim);
        out[n] = PairRun(std::min(pa.id, gb.prim.id), std::max(pa.id, gb.prim.id), ea.tag.info, b);
        n += touch;
    }
    return n;
}

// The lists of walk positions [w0, w1) and their big pairs, into `l`: room
// for every candidate is made once, each written and kept only if it touches
// (no branch on an outcome close to random in a pile). The walk is in id
// order and each list sorted by id, so the runs come out in canonical order
// unless a sphere meets a geom through dCollide.
void list_block(const PairInputs& in, const std::uint32_t* start, const ListEntry* next, const std::uint32_t* walk,
                std::size_t w0, std::size_t w1, Lane& l) {
    const GeomInfo* info = in.infos.info;
    std::size_t n = l.runs.size();
    l.runs.resize(n + (start[w1] - start[w0]) + (w1 - w0) * in.nbig);
    PairRun* out = l.runs.data();
    std::vector<BigPair> slow;
    for (std::size_t w = w0; w < w1; ++w) {
        const std::uint32_t a = walked(walk, w);
        const GeomInfo& ga = info[a];
        const std::uint32_t fa = ga.prim.flags;
        if (!listable(fa) || !(fa & kEnabled)) continue;
        GridEntry ea;
        sphere_aabb(ga.prim.p, ea.aabb);
        ea.tag = GridTag{ga.body, a, fa};
        n = list_sphere(in, ea, ga.prim, next, walk, start[w], start[w + 1], out, n);
        if (in.nbig) n = against_big(in, ea, ga.prim, out, n, slow);
    }
    l.runs.resize(n);
    for (const BigPair& p : slow) {
        const PrimData& pb = in.big_prims[p.big];
        if (p.a->flags & pb.flags & kSafe) l.generic(p.a->geom, pb.geom, in.max_contacts);
        else l.deferred.push_back(DeferredPair{p.a->geom, pb.geom});
    }
}

}  // namespace

NeighbourList::Check NeighbourList::check_block(const GeomInfo* info, std::size_t i0, std::size_t i1) const {
    const double skin2 = skin_ * skin_;
    const float* ref = ref_.data();
    Check c;
    for (std::size_t i = i0; i < i1; ++i) {
        const PrimData& p = info[i].prim;
        const float* r = ref + 4 * i;
        const bool listed = r[3] >= 0;
        const double dx = p.p[0] - r[0], dy = p.p[1] - r[1], dz = p.p[2] - r[2];
        const bool near = (dx * dx + dy * dy + dz * dz <= skin2) & (p.p[3] <= r[3]);
        c.ok &= (listable(p.flags) == listed) & (!listed | near);
        c.slots += slot_digest(i, p.id);
    }
    return c;
}

bool NeighbourList::covers(const void* owner, const GeomTable& infos) {
    if (owner != owner_ || owner == nullptr) return false;
    if (infos.size() != n_) return patched(infos);
    const std::size_t n = n_;
    const std::size_t blocks = task_count(n, kListBlock);
    std::vector<Check> checks(blocks);
    Check* out = checks.data();
    const GeomInfo* info = infos.view().info;
    const NeighbourList* self = this;
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(out, info, self, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) {
        out[b] = self->check_block(info, task_begin(n, blocks, b), task_begin(n, blocks, b + 1));
    }
    std::uint64_t slots = 0;
    bool ok = true;
    for (const Check& c : checks) slots += c.slots, ok &= c.ok;
    if (ok && slots == slots_) {
        ++lived_;
        ++counts_.uses;
        return true;
    }
    // Other geoms in the table's slots (bodies arrived, left or moved to
    // other slots, as on a rank after a migration): patched, or built afresh.
    if (slots != slots_) return patched(infos);
    // Spent: after a list that served fewer than two calls beyond its build,
    // the grid runs for longer each time before the next build: spheres that
    // move this fast gain nothing from a list.
    owner_ = nullptr;
    cooldown_ = lived_ < 2 ? std::min(kListMaxCooldown, std::max<std::size_t>(1, 2 * cooldown_)) : 0;
    wait_ = cooldown_;
    return false;
}

// A table whose geoms changed: patched when few did (a use), else built
// afresh at once (not left to the grid, whose merge sorts).
bool NeighbourList::patched(const GeomTable& infos) {
    if (patch(infos)) {
        ++lived_;
        ++counts_.uses;
        ++counts_.patches;
        return true;
    }
    owner_ = nullptr;
    return false;
}

bool NeighbourList::due() {
    if (wait_ > 0) {
        --wait_;
        return false;
    }
    return true;
}

void NeighbourList::others(const GeomTable& infos, std::vector<std::uint32_t>& out) const {
    out.clear();
    for (std::uint32_t i : outside_) {
        if (infos[i].prim.flags & kEnabled) out.push_back(i);
    }
}

std::uint64_t NeighbourList::digest() const {
    Fnv1a h;
    for (std::uint32_t s : start_) h.add(s);
    for (const ListEntry& e : next_) h.add(e.w);
    return h.value();
}

std::size_t NeighbourList::blocks() const { return task_count(n_, kListBlock); }

void NeighbourList::pairs(const PairInputs& in, Lane* lane) const {
    const std::size_t n = n_;
    const std::size_t blocks = this->blocks();
    const std::uint32_t* start = start_.data();
    const ListEntry* next = next_.data();
    const std::uint32_t* walk = walk_.empty() ? nullptr : walk_.data();
    const PairInputs* pin = &in;
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(pin, start, next, walk, lane, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) {
        Lane& l = lane[b];
        const double t0 = now_seconds();
        list_block(*pin, start, next, walk, task_begin(n, blocks, b), task_begin(n, blocks, b + 1), l);
        l.narrow += now_seconds() - t0;
    }
}

}  // namespace parode::omp
