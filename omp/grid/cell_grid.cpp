// Building the uniform grid of cell_grid.hpp: cell size from the largest AABB
// (with a small margin against rounding), integer cell keys of the AABBs' minimum
// corners, a stable counting sort (dense) or comparison sort (sparse), and the
// compact sorted entries.
// Trade-off: the dense counting sort runs in tasks (by z-slab), which costs an
// extra pass over the keys but leaves only prefix sums over tasks x slabs
// serial; the layout comes out identical for every thread count. The sparse
// path (rare: geoms scattered far apart) sorts serially.
#include "omp/grid/cell_grid.hpp"
#include "omp/runtime/task_split.hpp"
#include "util/scratch.hpp"

#include <algorithm>
#include <cmath>

namespace parode::omp {
namespace {

constexpr double kMargin = 1.0 + 1e-4;       // cell size over largest extent
constexpr double kMaxCells = 1152921504606846976.0;  // 2^60

constexpr std::size_t kBlock = 4096;  // geoms per partial bound
// Sorted positions ahead whose table record fill_entries prefetches: the
// table is in the space's list order, which after a few steps of ODE's own
// bookkeeping (moved geoms go to the front of its list) is not the cells'.
constexpr std::size_t kFillAhead = 8;

CellBounds item_bounds(const GeomTable& infos, const std::vector<std::uint32_t>& items) {
    const std::size_t n = items.size();
    const std::size_t nblocks = (n + kBlock - 1) / kBlock;
    std::vector<CellBounds> part(nblocks);
    CellBounds* out = part.data();
    const GeomView info = infos.view();
    const std::uint32_t* item = items.data();
#pragma omp taskloop num_tasks(task_count(nblocks, 1)) default(none) firstprivate(out, info, item, n, nblocks)
    for (std::size_t b = 0; b < nblocks; ++b) {
        CellBounds bounds;  // a local, stored once: neighbouring blocks' bounds share cache lines
        for (std::size_t j = b * kBlock; j < std::min(n, (b + 1) * kBlock); ++j) bounds.add(info, item[j]);
        out[b] = bounds;
    }
    CellBounds all;
    for (const CellBounds& b : part) all.add(b);
    return all;
}

}  // namespace

void CellGrid::choose_cells(const CellBounds& bounds, bool empty) {
    double lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        lo[k] = bounds.lo[k];
        hi[k] = bounds.hi[k];
    }
    const double ext = bounds.ext;
    h_ = ext > 0 ? ext * kMargin : 1.0;
    if (empty) std::fill(lo, lo + 3, 0.0), std::fill(hi, hi + 3, 0.0);
    for (;;) {
        inv_h_ = 1.0 / h_;
        double cells = 1;
        for (int k = 0; k < 3; ++k) {
            origin_[k] = lo[k];
            const double n = std::floor((hi[k] - lo[k]) * inv_h_) + 3;  // +2 padding
            dims_[k] = static_cast<std::uint64_t>(n);
            cells *= n;
        }
        if (cells < kMaxCells) break;
        h_ *= 2;  // absurdly spread scene: coarser cells keep keys in 64 bits
    }
    rows_[0] = dims_[0];
    rows_[1] = dims_[0] * dims_[1] - dims_[0];
    rows_[2] = dims_[0] * dims_[1];
    rows_[3] = dims_[0] * dims_[1] + dims_[0];
}

std::uint64_t CellGrid::cell_key(const dReal* aabb) const {
    std::uint64_t c[3];
    for (int k = 0; k < 3; ++k) {
        // Non-negative (origin is the minimum corner), so truncation is floor.
        const double x = (aabb[2 * k] - origin_[k]) * inv_h_;
        c[k] = std::min(static_cast<std::uint64_t>(x > 0 ? x : 0) + 1, dims_[k] - 2);
    }
    return (c[2] * dims_[1] + c[1]) * dims_[0] + c[0];
}

void CellGrid::compute_keys(const GeomTable& infos,
                            const std::vector<std::uint32_t>& items) {
    // Plain pointers: a task would copy a referenced vector (firstprivate).
    const std::size_t n = items.size();
    scratch_resize(raw_keys_, n);
    const GeomView info = infos.view();
    const std::uint32_t* item = items.data();
#pragma omp taskloop num_tasks(task_count(n, 2048))
    for (std::size_t j = 0; j < n; ++j) {
        dReal b[6];
        info.aabb(item[j], b);
        raw_keys_[j] = cell_key(b);
    }
}

// Stable counting sort by cell key, in tasks: items are first spread over
// z-slabs (a histogram per task, a prefix over tasks x slabs, a scatter per
// task), then each slab, whose cells form one key range, is sorted on its own.
void CellGrid::sort_dense(std::size_t ncells) {
    const std::size_t n = raw_keys_.size();
    const std::size_t nslabs = static_cast<std::size_t>(dims_[2]);
    const std::size_t tasks = task_count(n, 2048);
    slab_pos_.assign(tasks * nslabs, 0);
    scratch_resize(slab_items_, n);
    scratch_resize(order_, n);
    scratch_resize(start_, ncells + 1);
    count_slabs(tasks, nslabs);
    outer_inner_offsets(tasks, nslabs, slab_pos_, slab_start_);
    scatter_slabs(tasks, nslabs);
    sort_slabs(nslabs);
    start_[ncells] = static_cast<std::uint32_t>(n);
}

void CellGrid::count_slabs(std::size_t tasks, std::size_t nslabs) {
    const std::size_t n = raw_keys_.size();
    const std::uint64_t plane = dims_[0] * dims_[1];
    const std::uint64_t* key = raw_keys_.data();
    std::size_t* count = slab_pos_.data();
#pragma omp taskloop num_tasks(tasks) default(none) firstprivate(key, count, n, tasks, nslabs, plane)
    for (std::size_t t = 0; t < tasks; ++t) {
        for (std::size_t j = task_begin(n, tasks, t); j < task_begin(n, tasks, t + 1); ++j) {
            ++count[t * nslabs + static_cast<std::size_t>(key[j] / plane)];
        }
    }
}

void CellGrid::scatter_slabs(std::size_t tasks, std::size_t nslabs) {
    const std::size_t n = raw_keys_.size();
    const std::uint64_t plane = dims_[0] * dims_[1];
    const std::uint64_t* key = raw_keys_.data();
    std::size_t* pos = slab_pos_.data();
    std::uint32_t* out = slab_items_.data();
#pragma omp taskloop num_tasks(tasks) default(none) firstprivate(key, pos, out, n, tasks, nslabs, plane)
    for (std::size_t t = 0; t < tasks; ++t) {
        for (std::size_t j = task_begin(n, tasks, t); j < task_begin(n, tasks, t + 1); ++j) {
            out[pos[t * nslabs + static_cast<std::size_t>(key[j] / plane)]++] = static_cast<std::uint32_t>(j);
        }
    }
}

// Counting sort inside each slab: start_ holds counts, then first positions;
// the scatter advances them to the ends, and a shift restores the starts.
void CellGrid::sort_slabs(std::size_t nslabs) {
    const std::uint64_t plane = dims_[0] * dims_[1];
    const std::uint64_t* key = raw_keys_.data();
    const std::uint32_t* items = slab_items_.data();
    const std::size_t* slab = slab_start_.data();
    std::uint32_t* start = start_.data();
    std::uint32_t* order = order_.data();
#pragma omp taskloop num_tasks(task_count(nslabs, 1)) default(none) \
    firstprivate(key, items, slab, start, order, nslabs, plane)
    for (std::size_t z = 0; z < nslabs; ++z) {
        const std::size_t c0 = z * plane, c1 = c0 + plane;
        std::fill(start + c0, start + c1, 0u);
        for (std::size_t i = slab[z]; i < slab[z + 1]; ++i) ++start[key[items[i]]];
        std::uint32_t run = static_cast<std::uint32_t>(slab[z]);
        for (std::size_t c = c0; c < c1; ++c) {
            const std::uint32_t k = start[c];
            start[c] = run;
            run += k;
        }
        for (std::size_t i = slab[z]; i < slab[z + 1]; ++i) order[start[key[items[i]]]++] = items[i];
        for (std::size_t c = c1 - 1; c > c0; --c) start[c] = start[c - 1];
        start[c0] = static_cast<std::uint32_t>(slab[z]);
    }
}

void CellGrid::sort_sparse() {
    const std::size_t n = raw_keys_.size();
    order_.resize(n);
    for (std::size_t j = 0; j < n; ++j) order_[j] = static_cast<std::uint32_t>(j);
    std::sort(order_.begin(), order_.end(), [this](std::uint32_t a, std::uint32_t b) {
        return raw_keys_[a] != raw_keys_[b] ? raw_keys_[a] < raw_keys_[b] : a < b;
    });
    ukeys_.clear();
    ustart_.clear();
    for (std::size_t s = 0; s < n; ++s) {
        const std::uint64_t k = raw_keys_[order_[s]];
        if (ukeys_.empty() || ukeys_.back() != k) {
            ukeys_.push_back(k);
            ustart_.push_back(static_cast<std::uint32_t>(s));
        }
    }
    ustart_.push_back(static_cast<std::uint32_t>(n));
}

void CellGrid::fill_entries(const GeomTable& infos,
                            const std::vector<std::uint32_t>& items) {
    const std::size_t n = items.size();
    size_ = n;
    boxes_.resize(n);
    prims_.resize(n);
    scratch_resize(keys_, n);
    GridBox* box = boxes_.data();
    const GeomView info = infos.view();
    const std::uint32_t* item = items.data();
#pragma omp taskloop num_tasks(task_count(n, 2048)) firstprivate(box, info, item)
    for (std::size_t s = 0; s < n; ++s) {
        if (s + kFillAhead < n) __builtin_prefetch(&info.info[item[order_[s + kFillAhead]]]);
        const std::uint32_t j = order_[s];
        const GeomInfo& g = info.info[item[j]];
        dReal b[6];
        info.aabb(item[j], b);
        GridBox r;
        box_from_aabb(b, r.key);
        r.tag = GridTag{g.body, item[j], g.prim.flags};
        box[s] = r;
        prims_[s] = g.prim;
        keys_[s] = raw_keys_[j];
    }
}

void CellGrid::build(const GeomTable& infos, const std::vector<std::uint32_t>& items) {
    build(infos, items, item_bounds(infos, items));
}

void CellGrid::build(const GeomTable& infos, const std::vector<std::uint32_t>& items,
                     const CellBounds& bounds) {
    sort(infos, items, bounds);
    fill_entries(infos, items);
}

void CellGrid::sort(const GeomTable& infos, const std::vector<std::uint32_t>& items, const CellBounds& bounds) {
    size_ = 0;
    choose_cells(bounds, items.empty());
    compute_keys(infos, items);
    const double ncells = static_cast<double>(dims_[0]) * static_cast<double>(dims_[1]) *
                          static_cast<double>(dims_[2]);
    dense_ = ncells <= 4.0 * static_cast<double>(items.size()) + 4096.0;
    if (dense_) {
        sort_dense(static_cast<std::size_t>(ncells));
    } else {
        sort_sparse();
    }
}

void CellGrid::sparse_range(std::uint64_t k0, std::uint64_t k1, std::uint32_t& begin,
                            std::uint32_t& end) const {
    const auto b = std::lower_bound(ukeys_.begin(), ukeys_.end(), k0);
    const auto e = std::lower_bound(b, ukeys_.end(), k1 + 1);
    begin = ustart_[static_cast<std::size_t>(b - ukeys_.begin())];
    end = ustart_[static_cast<std::size_t>(e - ukeys_.begin())];
}

}  // namespace parode::omp
