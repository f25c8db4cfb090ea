// Building the neighbour list of neighbour_list.hpp: float references of the
// spheres, the walk in id order, the cells (the grid's sort, cell_grid.hpp)
// over a compact copy of the references, the pairs from the half stencil,
// and the lists in walk order.
// Trade-off: the pair search keeps a pair in the list of the sphere it starts
// from whenever that sphere comes first in the walk (in a pile built in id
// order, all but a few percent), placed later by the same task; the others
// are set aside, sorted in tasks by the list that takes them and added to it
// (a sort the few need, instead of atomic placement of every pair), so the
// lists come out the same for any thread count.
#include "omp/grid/neighbour_list.hpp"
#include "omp/grid/sphere_search.hpp"
#include "omp/runtime/task_split.hpp"
#include "util/scratch.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace parode::omp {
namespace {

constexpr double kSkin = 0.1;  // skin over the largest radius

double squared_distance(const dReal* a, const dReal* b) {
    const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

// `keys` sorted in tasks: blocks sorted, then runs merged pairwise, a task a
// pair, until one is left. The keys are distinct, so the result is the same
// on any thread count.
void sort_in_tasks(std::vector<std::uint64_t>& keys) {
    const std::size_t n = keys.size(), blocks = task_count(n, 8 * kListBlock);
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

// The items of `grid` (sorted, CellGrid::sort) laid out in cell order.
CellSpheres cell_spheres(const CellGrid& grid, const std::vector<std::uint32_t>& items, const float* ref,
                         const std::uint32_t* pos) {
    const std::size_t n = items.size(), blocks = task_count(n, kListBlock);
    CellSpheres c;
    c.resize(n);
    CellSpheres* out = &c;
    const CellGrid* g = &grid;
    const std::uint32_t* item = items.data();
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(out, g, item, ref, pos, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) {
        for (std::size_t s = task_begin(n, blocks, b); s < task_begin(n, blocks, b + 1); ++s) {
            const std::uint32_t j = g->order()[s], i = item[j];
            out->x[s].v = ref[4 * i];
            out->y[s].v = ref[4 * i + 1];
            out->z[s].v = ref[4 * i + 2];
            out->r[s].v = ref[4 * i + 3];
            out->walk[s].v = pos ? pos[i] : i;
            out->key[s].v = g->item_key(j);
        }
    }
    return c;
}

// Every sphere's pairs, in tasks over blocks of cell positions (found[t] for
// block t), and how many each keeps at own[walk position].
void find_pairs(const CellGrid& grid, const CellSpheres& cells, float need, std::vector<Found>& found,
                std::uint32_t* own, bool simd) {
    const std::size_t n = cells.size(), blocks = found.size();
    const CellGrid* g = &grid;
    const CellSpheres* c = &cells;
    Found* out = found.data();
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(g, c, out, own, need, n, blocks, simd)
    for (std::size_t t = 0; t < blocks; ++t) {
        const std::size_t s0 = task_begin(n, blocks, t), s1 = task_begin(n, blocks, t + 1);
        out[t].own.resize(4 * (s1 - s0));
        for (std::size_t s = s0; s < s1; ++s) {
            if (s + 16 < n) g->prefetch_stencil(c->key[s + 16].v);
            own[c->walk[s].v] = partners(*g, *c, s, need, out[t], simd);
        }
        out[t].own.resize(out[t].kept);
    }
}

// The pairs set aside by all tasks, in one array sorted in tasks: by the
// walk position whose list takes them, then the other's.
std::vector<std::uint64_t> spilled_pairs(const std::vector<Found>& found) {
    std::vector<std::uint64_t> all;
    for (const Found& f : found) all.insert(all.end(), f.spilled.begin(), f.spilled.end());
    sort_in_tasks(all);
    return all;
}

// fn(w, first, last) for each run [first, last) of `spilled` bound for the
// list of walk position w, in tasks (a run belongs to the task its first
// pair falls in).
template <class Fn>
void for_spilled_runs(const std::vector<std::uint64_t>& spilled, Fn fn) {
    const std::size_t n = spilled.size(), tasks = task_count(n, 8 * kListBlock);
    const std::uint64_t* p = spilled.data();
#pragma omp taskloop num_tasks(tasks) default(none) firstprivate(p, fn, n, tasks)
    for (std::size_t t = 0; t < tasks; ++t) {
        const std::size_t i1 = task_begin(n, tasks, t + 1);
        std::size_t i = task_begin(n, tasks, t);
        while (i < i1 && i > 0 && (p[i] >> 32) == (p[i - 1] >> 32)) ++i;  // that run is the previous task's
        while (i < i1) {
            std::size_t j = i + 1;
            while (j < n && (p[j] >> 32) == (p[i] >> 32)) ++j;
            fn(static_cast<std::size_t>(p[i] >> 32), p + i, p + j);
            i = j;
        }
    }
}

// The lists' starts (start[w] for walk position w, n + 1 of them): the pairs
// each sphere kept plus those set aside for it, summed in tasks over blocks
// of walk positions (block totals, their prefix, then each block's own).
void list_starts(const std::vector<std::uint64_t>& spilled, const std::uint32_t* own, std::size_t n,
                 std::uint32_t* start) {
    const std::size_t blocks = task_count(n, kListBlock);
    start[0] = 0;
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(own, start, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) {
        for (std::size_t w = task_begin(n, blocks, b); w < task_begin(n, blocks, b + 1); ++w) start[w + 1] = own[w];
    }
    for_spilled_runs(spilled, [start](std::size_t w, const std::uint64_t* first, const std::uint64_t* last) {
        start[w + 1] += static_cast<std::uint32_t>(last - first);
    });
    std::vector<std::uint32_t> total(blocks + 1, 0);
    std::uint32_t* sum = total.data();
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(sum, start, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) {
        std::uint32_t s = 0;
        for (std::size_t w = task_begin(n, blocks, b); w < task_begin(n, blocks, b + 1); ++w) s += start[w + 1];
        sum[b + 1] = s;
    }
    for (std::size_t b = 0; b < blocks; ++b) total[b + 1] += total[b];
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(sum, start, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) {
        std::uint32_t s = sum[b];
        for (std::size_t w = task_begin(n, blocks, b); w < task_begin(n, blocks, b + 1); ++w) start[w + 1] = s += start[w + 1];
    }
}

bool before(const ListEntry& a, const ListEntry& b) { return a.w < b.w; }
void sort_list(ListEntry* first, ListEntry* last) { std::sort(first, last, before); }

// Each sphere's kept pairs to the front of its list, sorted, in the tasks of
// find_pairs; then the pairs set aside after them, and those lists sorted
// again.
void place_lists(const CellSpheres& cells, const std::vector<Found>& found, const std::vector<std::uint64_t>& spilled,
                 const std::uint32_t* own, const std::uint32_t* start, ListEntry* next) {
    const std::size_t n = cells.size(), blocks = found.size();
    const CellSpheres* c = &cells;
    const Found* in = found.data();
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(c, in, own, start, next, n, blocks)
    for (std::size_t t = 0; t < blocks; ++t) {
        const ListEntry* from = in[t].own.data();
        for (std::size_t s = task_begin(n, blocks, t); s < task_begin(n, blocks, t + 1); ++s) {
            const std::uint32_t w = c->walk[s].v, m = own[w];
            ListEntry* to = next + start[w];
            std::copy(from, from + m, to);
            if (!std::is_sorted(to, to + m, before)) sort_list(to, to + m);
            from += m;
        }
    }
    for_spilled_runs(spilled, [own, start, next](std::size_t w, const std::uint64_t* first, const std::uint64_t* last) {
        ListEntry* to = next + start[w] + own[w];
        for (const std::uint64_t* p = first; p < last; ++p) (to++)->w = static_cast<std::uint32_t>(*p);
        sort_list(next + start[w], next + start[w + 1]);
    });
}

}  // namespace

float radius_up(double r) {
    float f = static_cast<float>(r);
    if (static_cast<double>(f) < r) f = std::nextafter(f, HUGE_VALF);
    return f;
}

// No list: its memory is given back (a space that declines once usually
// declines every time).
void NeighbourList::decline() {
    owner_ = nullptr;
    n_ = 0;
    std::vector<float>().swap(ref_);
    std::vector<std::uint32_t>().swap(start_);
    std::vector<ListEntry>().swap(next_);
    std::vector<std::uint32_t>().swap(outside_);
    std::vector<std::uint32_t>().swap(walk_);
    std::vector<std::uint32_t>().swap(ids_);
    ++counts_.declined;
    wait_ = kListMaxCooldown;
}

// References of table entries [i0, i1) (a float centre and a rounded-up
// radius for a plain sphere, radius -1 for the others), and what the build
// needs to know of them.
NeighbourList::Part NeighbourList::reference(const GeomView& t, std::size_t i0, std::size_t i1) {
    Part part;  // a local, stored once: neighbouring blocks' parts share cache lines
    for (std::size_t i = i0; i < i1; ++i) {
        const PrimData& p = t.info[i].prim;
        part.in_id_order &= i == i0 || t.info[i - 1].prim.id < p.id;
        part.slots += slot_digest(i, p.id);
        ids_[i] = p.id;
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
        part.shift = std::max(part.shift, squared_distance(p.p, back));  // squared until the block ends
        part.rmax = std::max(part.rmax, p.p[3]);
        ++part.listed;
        part.bounds.add(t, i);
    }
    part.shift = std::sqrt(part.shift);
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
    const std::size_t n = n_, blocks = task_count(n, kListBlock);
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
    scratch_resize(walk_, n);
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

// The lists: the listed spheres laid out in cell order, their pairs found
// in tasks, then placed by walk position.
void NeighbourList::link(const CellGrid& grid, const std::vector<std::uint32_t>& items, const std::uint32_t* pos,
                         float need) {
    const CellSpheres cells = cell_spheres(grid, items, ref_.data(), pos);
    std::vector<Found> found(task_count(items.size(), kListBlock));
    std::vector<std::uint32_t> own;
    scratch_assign(own, n_, 0u);
    find_pairs(grid, cells, need, found, own.data(), simd_);
    const std::vector<std::uint64_t> spilled = spilled_pairs(found);
    scratch_resize(start_, n_ + 1);
    list_starts(spilled, own.data(), n_, start_.data());
    scratch_resize(next_, start_[n_]);
    place_lists(cells, found, spilled, own.data(), start_.data(), next_.data());
}

bool NeighbourList::build(const void* owner, const GeomTable& infos, CellGrid& grid) {
    const GeomView t = infos.view();
    n_ = infos.size();
    scratch_resize(ref_, 4 * n_);
    scratch_resize(ids_, n_);
    const std::size_t n = n_, blocks = task_count(n, kListBlock);
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
        all.slots += p.slots;
        all.rmax = std::max(all.rmax, p.rmax);
        all.shift = std::max(all.shift, p.shift);
        all.bounds.add(p.bounds);
    }
    skin_ = kSkin * all.rmax;
    rmax_ = all.rmax;
    if (all.enabled_outside > kMaxOutside || !(all.shift <= 0.25 * skin_)) {
        decline();
        return false;
    }
    std::vector<std::uint32_t> items;
    list_members(parts, items);
    // The list holds every pair whose reference centres lie within the sum of
    // their radii and twice the skin; cells also cover the references'
    // rounding, as the keys come from the exact centres.
    const double need = 2 * skin_;
    all.bounds.ext += need + 2 * all.shift;
    grid.sort(infos, items, all.bounds);
    const std::vector<std::uint32_t> pos = walk_in_id_order(t, all.in_id_order);
    link(grid, items, pos.empty() ? nullptr : pos.data(), radius_up(need));
    owner_ = owner;
    slots_ = all.slots;
    lived_ = 0;
    ++counts_.builds;
    return true;
}

}  // namespace parode::omp
