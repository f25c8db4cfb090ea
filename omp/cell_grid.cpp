// Building the uniform grid of cell_grid.hpp: cell size from the largest AABB
// (with a small margin against rounding), integer cell keys of the AABBs' minimum
// corners, a stable counting sort (dense) or comparison sort (sparse), and the
// compact sorted entries.
// Trade-off: keys and entries are computed in tasks but the counting sort is
// serial: two passes over 8-byte keys, small next to the narrowphase, and the
// layout comes out identical for every thread count.
#include "cell_grid.hpp"
#include "task_split.hpp"

#include <algorithm>
#include <cmath>

namespace parode::omp {
namespace {

constexpr double kMargin = 1.0 + 1e-4;       // cell size over largest extent
constexpr double kMaxCells = 1152921504606846976.0;  // 2^60

// Minimum corners' bounds and the largest extent of a block of geoms.
struct Bounds {
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL};
    double hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    double ext = 0;
    void add(const GeomInfo& g) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], g.aabb[2 * k]);
            hi[k] = std::max(hi[k], g.aabb[2 * k]);
        }
        ext = std::max(ext, g.extent);
    }
    void add(const Bounds& b) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], b.lo[k]);
            hi[k] = std::max(hi[k], b.hi[k]);
        }
        ext = std::max(ext, b.ext);
    }
};

constexpr std::size_t kBlock = 4096;  // geoms per partial bound

Bounds item_bounds(const std::vector<GeomInfo>& infos, const std::vector<std::uint32_t>& items) {
    const std::size_t n = items.size();
    const std::size_t nblocks = (n + kBlock - 1) / kBlock;
    std::vector<Bounds> part(nblocks);
    Bounds* out = part.data();
    const GeomInfo* info = infos.data();
    const std::uint32_t* item = items.data();
#pragma omp taskloop num_tasks(task_count(nblocks, 1)) default(none) firstprivate(out, info, item, n, nblocks)
    for (std::size_t b = 0; b < nblocks; ++b) {
        for (std::size_t j = b * kBlock; j < std::min(n, (b + 1) * kBlock); ++j) out[b].add(info[item[j]]);
    }
    Bounds all;
    for (const Bounds& b : part) all.add(b);
    return all;
}

}  // namespace

void CellGrid::choose_cells(const std::vector<GeomInfo>& infos,
                            const std::vector<std::uint32_t>& items) {
    const Bounds bounds = item_bounds(infos, items);
    double lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        lo[k] = bounds.lo[k];
        hi[k] = bounds.hi[k];
    }
    const double ext = bounds.ext;
    h_ = ext > 0 ? ext * kMargin : 1.0;
    if (items.empty()) std::fill(lo, lo + 3, 0.0), std::fill(hi, hi + 3, 0.0);
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

std::uint64_t CellGrid::cell_key(const GeomInfo& g) const {
    std::uint64_t c[3];
    for (int k = 0; k < 3; ++k) {
        const double x = std::floor((g.aabb[2 * k] - origin_[k]) * inv_h_);
        c[k] = std::min(static_cast<std::uint64_t>(x < 0 ? 0 : x) + 1, dims_[k] - 2);
    }
    return (c[2] * dims_[1] + c[1]) * dims_[0] + c[0];
}

void CellGrid::compute_keys(const std::vector<GeomInfo>& infos,
                            const std::vector<std::uint32_t>& items) {
    // Plain pointers: a task would copy a referenced vector (firstprivate).
    const std::size_t n = items.size();
    raw_keys_.resize(n);
    const GeomInfo* info = infos.data();
    const std::uint32_t* item = items.data();
#pragma omp taskloop num_tasks(task_count(n, 2048))
    for (std::size_t j = 0; j < n; ++j) raw_keys_[j] = cell_key(info[item[j]]);
}

void CellGrid::sort_dense(std::size_t ncells) {
    const std::size_t n = raw_keys_.size();
    start_.assign(ncells + 1, 0);
    for (std::size_t j = 0; j < n; ++j) ++start_[raw_keys_[j] + 1];
    for (std::size_t c = 0; c < ncells; ++c) start_[c + 1] += start_[c];
    std::vector<std::uint32_t>& next = ustart_;  // scratch: running fill position
    next.assign(start_.begin(), start_.end() - 1);
    order_.resize(n);
    for (std::size_t j = 0; j < n; ++j) order_[next[raw_keys_[j]]++] = static_cast<std::uint32_t>(j);
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

void CellGrid::fill_entries(const std::vector<GeomInfo>& infos,
                            const std::vector<std::uint32_t>& items) {
    const std::size_t n = items.size();
    entries_.resize(n);
    prims_.resize(n);
    keys_.resize(n);
    const GeomInfo* info = infos.data();
    const std::uint32_t* item = items.data();
#pragma omp taskloop num_tasks(task_count(n, 2048))
    for (std::size_t s = 0; s < n; ++s) {
        const std::uint32_t j = order_[s];
        const GeomInfo& g = info[item[j]];
        GridEntry& e = entries_[s];
        std::copy(g.aabb, g.aabb + 6, e.aabb);
        e.body = g.body;
        e.info = item[j];
        e.flags = g.flags;
        prims_[s] = g.prim;
        keys_[s] = raw_keys_[j];
    }
}

void CellGrid::build(const std::vector<GeomInfo>& infos, const std::vector<std::uint32_t>& items) {
    choose_cells(infos, items);
    compute_keys(infos, items);
    const double ncells = static_cast<double>(dims_[0]) * static_cast<double>(dims_[1]) *
                          static_cast<double>(dims_[2]);
    dense_ = ncells <= 4.0 * static_cast<double>(items.size()) + 4096.0;
    if (dense_) {
        sort_dense(static_cast<std::size_t>(ncells));
    } else {
        sort_sparse();
    }
    fill_entries(infos, items);
}

void CellGrid::sparse_range(std::uint64_t k0, std::uint64_t k1, std::uint32_t& begin,
                            std::uint32_t& end) const {
    const auto b = std::lower_bound(ukeys_.begin(), ukeys_.end(), k0);
    const auto e = std::lower_bound(b, ukeys_.end(), k1 + 1);
    begin = ustart_[static_cast<std::size_t>(b - ukeys_.begin())];
    end = ustart_[static_cast<std::size_t>(e - ukeys_.begin())];
}

}  // namespace parode::omp
