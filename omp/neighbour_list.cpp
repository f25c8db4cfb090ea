// The neighbour list of neighbour_list.hpp: the check that it still covers the
// spheres, its build from the grid's half stencil, and the pass over its pairs.
// Trade-off: the build places each pair with an atomic increment, in whatever
// order the tasks run, and then sorts every list: a little more work than a
// serial counting sort, but all of it in tasks, and the lists come out the
// same for any thread count.
#include "neighbour_list.hpp"
#include "task_split.hpp"
#include "util/substages.hpp"

#include <algorithm>
#include <cmath>

namespace parode::omp {
namespace {

constexpr double kSkin = 0.1;  // skin over the largest radius
constexpr std::size_t kMaxOutside = 64;  // enabled geoms outside the list, tested against every sphere
constexpr std::size_t kBlock = 2048;     // table entries per task
constexpr std::size_t kMaxCooldown = 16;

bool listable(std::uint32_t f) { return (f & kSphere) && !(f & kAux) && (f & kFinite); }

// The radius as a float no smaller than it.
float radius_up(double r) {
    float f = static_cast<float>(r);
    if (static_cast<double>(f) < r) f = std::nextafter(f, HUGE_VALF);
    return f;
}

double squared_distance(const dReal* a, const dReal* b) {
    const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

// `keys` sorted in tasks: blocks sorted, then runs merged pairwise, a task a
// pair, until one is left. The keys are distinct, so the result is the same
// on any thread count.
void sort_in_tasks(std::vector<std::uint64_t>& keys) {
    const std::size_t n = keys.size(), blocks = task_count(n, 8 * kBlock);
    std::vector<std::uint64_t> spare(n);
    std::uint64_t* a = keys.data();
    std::uint64_t* b = spare.data();
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(a, n, blocks)
    for (std::size_t k = 0; k < blocks; ++k) std::sort(a + task_begin(n, blocks, k), a + task_begin(n, blocks, k + 1));
    for (std::size_t width = 1; width < blocks; width *= 2) {
        const std::size_t pairs = (blocks + 2 * width - 1) / (2 * width);
#pragma omp taskloop num_tasks(pairs) default(none) firstprivate(a, b, n, blocks, width, pairs)
        for (std::size_t p = 0; p < pairs; ++p) {
            const std::size_t lo = task_begin(n, blocks, 2 * p * width);
            const std::size_t mid = task_begin(n, blocks, std::min(blocks, (2 * p + 1) * width));
            const std::size_t hi = task_begin(n, blocks, std::min(blocks, (2 * p + 2) * width));
            std::merge(a + lo, a + mid, a + mid, a + hi, b + lo);
        }
        std::swap(a, b);
    }
    if (a != keys.data()) keys.swap(spare);
}

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
std::size_t list_sphere(const PairInputs& in, const GridEntry& ea, const PrimData& pa, const std::uint32_t* next,
                        const std::uint32_t* walk, std::uint32_t k0, std::uint32_t k1, PairRun* out, std::size_t n) {
    const GeomInfo* info = in.infos.info;
    for (std::uint32_t k = k0; k < k1; ++k) {
        const std::uint32_t b = walked(walk, next[k]);
        const GeomInfo& gb = info[b];
        dReal bb[6];
        sphere_aabb(gb.prim.p, bb);
        const GridTag tb{gb.body, b, gb.prim.flags};
        const bool touch = ((gb.prim.flags & kEnabled) != 0) & aabb_overlap(ea.aabb, bb) &
                           tags_pass(in, ea.tag, tb) & (in.max_contacts >= 1) & fast_touch(pa, true, gb.prim, true);
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
void list_block(const PairInputs& in, const std::uint32_t* start, const std::uint32_t* next, const std::uint32_t* walk,
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

bool NeighbourList::check_block(const GeomInfo* info, std::size_t i0, std::size_t i1) const {
    const double skin2 = skin_ * skin_;
    const float* ref = ref_.data();
    bool ok = true;
    for (std::size_t i = i0; i < i1; ++i) {
        const PrimData& p = info[i].prim;
        const float* r = ref + 4 * i;
        const bool listed = r[3] >= 0;
        const double dx = p.p[0] - r[0], dy = p.p[1] - r[1], dz = p.p[2] - r[2];
        const bool near = (dx * dx + dy * dy + dz * dz <= skin2) & (p.p[3] <= r[3]);
        ok &= (listable(p.flags) == listed) & (!listed | near);
    }
    return ok;
}

bool NeighbourList::covers(const void* owner, const GeomTable& infos) {
    if (owner != owner_ || infos.size() != n_ || owner == nullptr) return false;
    const std::size_t n = n_;
    const std::size_t blocks = task_count(n, kBlock);
    std::vector<unsigned char> ok(blocks, 0);
    unsigned char* out = ok.data();
    const GeomInfo* info = infos.view().info;
    const NeighbourList* self = this;
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(out, info, self, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) {
        out[b] = self->check_block(info, task_begin(n, blocks, b), task_begin(n, blocks, b + 1));
    }
    if (std::all_of(ok.begin(), ok.end(), [](unsigned char c) { return c != 0; })) {
        ++lived_;
        ++counts_.uses;
        return true;
    }
    // Spent. After a list that served fewer than two calls beyond its build,
    // the grid runs for longer each time before the next build: spheres that
    // move this fast gain nothing from a list.
    cooldown_ = lived_ < 2 ? std::min(kMaxCooldown, std::max<std::size_t>(1, 2 * cooldown_)) : 0;
    wait_ = cooldown_;
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

// No list: its memory is given back (a space that declines once usually
// declines every time).
void NeighbourList::decline() {
    owner_ = nullptr;
    n_ = 0;
    std::vector<float>().swap(ref_);
    std::vector<std::uint32_t>().swap(start_);
    std::vector<std::uint32_t>().swap(next_);
    std::vector<std::uint32_t>().swap(outside_);
    std::vector<std::uint32_t>().swap(walk_);
    ++counts_.declined;
    wait_ = kMaxCooldown;
}

// References of table entries [i0, i1) (a float centre and a rounded-up
// radius for a plain sphere, radius -1 for the others), and what the build
// needs to know of them.
NeighbourList::Part NeighbourList::reference(const GeomView& t, std::size_t i0, std::size_t i1) {
    Part part;  // a local, stored once: neighbouring blocks' parts share cache lines
    for (std::size_t i = i0; i < i1; ++i) {
        const PrimData& p = t.info[i].prim;
        part.in_id_order &= i == i0 || t.info[i - 1].prim.id < p.id;
        float* r = ref_.data() + 4 * i;
        if (!listable(p.flags)) {
            r[3] = -1;
            ++part.outside;
            part.enabled_outside += (p.flags & kEnabled) != 0;
            continue;
        }
        for (int k = 0; k < 3; ++k) r[k] = static_cast<float>(p.p[k]);
        r[3] = radius_up(p.p[3]);
        const double back[3] = {r[0], r[1], r[2]};
        part.shift = std::max(part.shift, std::sqrt(squared_distance(p.p, back)));
        part.rmax = std::max(part.rmax, p.p[3]);
        ++part.listed;
        part.bounds.add(t, i);
    }
    if (i1 > i0) part.first_id = t.info[i0].prim.id, part.last_id = t.info[i1 - 1].prim.id;
    return part;
}

// The walk: table entries in id order, so that the pass over the lists gives
// its runs in canonical order (the merge then writes them without sorting).
// World's one-process space is in id order already (walk_ stays empty); a
// rank's table holds owned bodies and ghosts in local order, sorted here once
// a build. Returns each entry's walk position (empty: its table index).
std::vector<std::uint32_t> NeighbourList::walk_in_id_order(const GeomView& t, bool in_order) {
    walk_.clear();
    if (in_order) return {};
    const std::size_t n = n_, blocks = task_count(n, kBlock);
    std::vector<std::uint64_t> keys(n);
    std::uint64_t* key = keys.data();
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(key, t, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) {
        for (std::size_t i = task_begin(n, blocks, b); i < task_begin(n, blocks, b + 1); ++i) {
            key[i] = std::uint64_t{t.info[i].prim.id} << 32 | i;
        }
    }
    sort_in_tasks(keys);
    key = keys.data();  // the sort may hand back its other buffer
    walk_.resize(n);
    std::vector<std::uint32_t> pos(n);
    std::uint32_t* walk = walk_.data();
    std::uint32_t* at = pos.data();
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(key, walk, at, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) {
        for (std::size_t w = task_begin(n, blocks, b); w < task_begin(n, blocks, b + 1); ++w) {
            walk[w] = static_cast<std::uint32_t>(key[w]);
            at[walk[w]] = static_cast<std::uint32_t>(w);
        }
    }
    return pos;
}

// The plain spheres (items, for the grid) and the other geoms (outside_), in
// table order, block by block in tasks.
void NeighbourList::list_members(const std::vector<Part>& parts, std::vector<std::uint32_t>& items) {
    std::vector<std::array<std::size_t, 2>> counts(parts.size());
    for (std::size_t b = 0; b < parts.size(); ++b) counts[b] = {parts[b].listed, parts[b].outside};
    const float* ref = ref_.data();
    split_in_order(n_, counts, [ref](std::size_t i) { return ref[4 * i + 3] >= 0 ? 1 : 2; }, items, outside_);
}

// Pairs of sorted grid spheres within the sum of their (rounded-up) radii
// plus `reach`, as (lower, higher) walk positions (pos[table index]; null:
// the table index itself), per chunk of sorted grid positions.
void NeighbourList::find_pairs(const CellGrid& grid, double reach, const std::uint32_t* pos,
                               std::vector<std::vector<std::uint64_t>>& found) const {
    const std::size_t n = grid.size();
    const std::size_t chunks = found.size();
    const CellGrid* g = &grid;
    const float* ref = ref_.data();
    std::vector<std::uint64_t>* out = found.data();
#pragma omp taskloop num_tasks(chunks) default(none) firstprivate(g, ref, out, n, chunks, reach, pos)
    for (std::size_t c = 0; c < chunks; ++c) {
        std::vector<std::uint64_t>& mine = out[c];
        const PrimData* prim = g->prims();
        for (std::size_t s = task_begin(n, chunks, c); s < task_begin(n, chunks, c + 1); ++s) {
            const std::uint32_t ta = g->tag(s).info;
            const Spans sp = spans_of(*g, s);
            for (int r = 0; r < 5; ++r) {
                for (std::uint32_t b = sp.begin[r]; b < sp.end[r]; ++b) {
                    const std::uint32_t tb = g->tag(b).info;
                    const double t = static_cast<double>(ref[4 * ta + 3]) + ref[4 * tb + 3] + reach;
                    if (!(squared_distance(prim[s].p, prim[b].p) <= t * t * (1 + 1e-9))) continue;
                    const std::uint64_t pa = pos ? pos[ta] : ta, pb = pos ? pos[tb] : tb;
                    mine.push_back(std::min(pa, pb) << 32 | std::max(pa, pb));
                }
            }
        }
    }
}

// The pairs as one list per lower walk position, each sorted: counts and
// places taken with atomic increments (in tasks, in any order), then each
// list sorted, so the result does not depend on the order.
void NeighbourList::join(const std::vector<std::vector<std::uint64_t>>& found) {
    const std::size_t chunks = found.size(), n = n_;
    start_.assign(n + 1, 0);
    const std::vector<std::uint64_t>* in = found.data();
    std::uint32_t* start = start_.data();
#pragma omp taskloop num_tasks(chunks) default(none) firstprivate(in, start, chunks)
    for (std::size_t c = 0; c < chunks; ++c) {
        for (std::uint64_t p : in[c]) __atomic_fetch_add(&start[(p >> 32) + 1], 1u, __ATOMIC_RELAXED);
    }
    for (std::size_t i = 1; i <= n; ++i) start_[i] += start_[i - 1];
    next_.resize(start_[n]);
    std::vector<std::uint32_t> place(start_.begin(), start_.end() - 1);
    std::uint32_t* at = place.data();
    std::uint32_t* next = next_.data();
#pragma omp taskloop num_tasks(chunks) default(none) firstprivate(in, at, next, chunks)
    for (std::size_t c = 0; c < chunks; ++c) {
        for (std::uint64_t p : in[c]) {
            next[__atomic_fetch_add(&at[p >> 32], 1u, __ATOMIC_RELAXED)] = static_cast<std::uint32_t>(p);
        }
    }
    const std::size_t blocks = task_count(n, kBlock);
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(start, next, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) {
        for (std::size_t i = task_begin(n, blocks, b); i < task_begin(n, blocks, b + 1); ++i) {
            std::sort(next + start[i], next + start[i + 1]);
        }
    }
}

bool NeighbourList::build(const void* owner, const GeomTable& infos, CellGrid& grid) {
    const GeomView t = infos.view();
    n_ = infos.size();
    ref_.resize(4 * n_);
    const std::size_t n = n_, blocks = task_count(n, kBlock);
    std::vector<Part> parts(blocks);
    Part* part = parts.data();
    NeighbourList* self = this;
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(part, self, t, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) part[b] = self->reference(t, task_begin(n, blocks, b), task_begin(n, blocks, b + 1));
    Part all;
    std::uint32_t last_id = 0;
    bool any = false;
    for (const Part& p : parts) {
        all.in_id_order &= p.in_id_order && (!any || p.first_id > last_id);
        if (p.listed + p.outside > 0) last_id = p.last_id, any = true;
        all.enabled_outside += p.enabled_outside;
        all.rmax = std::max(all.rmax, p.rmax);
        all.shift = std::max(all.shift, p.shift);
        all.bounds.add(p.bounds);
    }
    skin_ = kSkin * all.rmax;
    if (all.enabled_outside > kMaxOutside || !(all.shift <= 0.25 * skin_)) {
        decline();
        return false;
    }
    std::vector<std::uint32_t> items;
    list_members(parts, items);
    const double reach = 2 * skin_ + 2 * all.shift;
    all.bounds.ext += reach;
    grid.build(infos, items, all.bounds);
    const std::vector<std::uint32_t> pos = walk_in_id_order(t, all.in_id_order);
    std::vector<std::vector<std::uint64_t>> found(task_count(items.size(), kBlock));
    find_pairs(grid, reach, pos.empty() ? nullptr : pos.data(), found);
    join(found);
    owner_ = owner;
    lived_ = 0;
    ++counts_.builds;
    return true;
}

void NeighbourList::others(const GeomTable& infos, std::vector<std::uint32_t>& out) const {
    out.clear();
    for (std::uint32_t i : outside_) {
        if (infos[i].prim.flags & kEnabled) out.push_back(i);
    }
}

std::size_t NeighbourList::blocks() const { return task_count(n_, kBlock); }

void NeighbourList::pairs(const PairInputs& in, Lane* lane) const {
    const std::size_t n = n_;
    const std::size_t blocks = this->blocks();
    const std::uint32_t* start = start_.data();
    const std::uint32_t* next = next_.data();
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
