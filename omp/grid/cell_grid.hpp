// Uniform grid over the "small" geoms: each geom lives in the one cell holding
// the minimum corner of its AABB, cells are at least as wide as the largest such
// AABB, so two overlapping AABBs sit in the same or adjacent cells and a half
// stencil (the cell itself plus 13 forward neighbours) finds every pair once.
// Geoms are stored sorted by cell key, each as one 64-byte GridBox (its AABB,
// maxima negated, and a 16-byte tag: body, info index, flags), the record the
// pair search reads (grid_boxes.hpp). A dense cell-start table is used when the
// cells number at most a few per geom, otherwise sorted occupied keys with
// binary search: memory stays linear in the number of geoms either way.
// Trade-off: one cell size for all geoms, so geoms much larger than typical are
// kept out (the caller's "big" list); a counting sort per call instead of any
// incremental structure, which keeps every call independent of the last.
#pragma once
#include <ode/ode.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "omp/grid/geom_info.hpp"
#include "omp/grid/grid_boxes.hpp"

namespace parode::omp {

// One geom's AABB and tag in one record: the big list's geoms, and what
// CellGrid::entry assembles for a grid geom tested against them.
struct alignas(64) GridEntry {
    dReal aabb[6];
    GridTag tag;
};

// The grid entry of geom `i` of the table.
inline GridEntry grid_entry(const GeomView& t, std::uint32_t i) {
    GridEntry e;
    t.aabb(i, e.aabb);
    e.tag = GridTag{t.info[i].body, i, t.flags(i)};
    return e;
}

// Bounds of the geoms' minimum corners and their largest extent.
struct CellBounds {
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL};
    double hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    double ext = 0;
    // A finite geom's AABB and its largest side (aabb_extent).
    void add(const dReal b[6], dReal extent) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], b[2 * k]);
            hi[k] = std::max(hi[k], b[2 * k]);
        }
        ext = std::max(ext, extent);
    }
    // Geom i of the table: its AABB read once (GeomView::extent's value, which
    // is aabb_extent of that AABB for a finite geom, 0 otherwise).
    void add(const GeomView& t, std::size_t i) {
        dReal b[6];
        t.aabb(i, b);
        add(b, (t.flags(i) & kFinite) ? aabb_extent(b) : 0);
    }
    void add(const CellBounds& b) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], b.lo[k]);
            hi[k] = std::max(hi[k], b.hi[k]);
        }
        ext = std::max(ext, b.ext);
    }
};

class CellGrid {
public:
    // Where the sorted entries and prims live (slots kSlotEntries, kSlotPrims).
    void set_scratch(ScratchPool* pool) {
        boxes_.set_pool(pool);
        prims_.set_pool(pool);
    }
    // Sort the geoms `items` (indices into `infos`, all finite) into cells.
    void build(const GeomTable& infos, const std::vector<std::uint32_t>& items);
    // The same, with the items' bounds already known.
    void build(const GeomTable& infos, const std::vector<std::uint32_t>& items,
               const CellBounds& bounds);
    // Only the cells and the items' order in them, no entries (size() is 0
    // afterwards): for a caller that lays out its own copy of the items.
    void sort(const GeomTable& infos, const std::vector<std::uint32_t>& items, const CellBounds& bounds);
    // After sort or build: the item at each sorted position, and each item's
    // cell key (by item position).
    const std::uint32_t* order() const { return order_.data(); }
    std::uint64_t item_key(std::size_t j) const { return raw_keys_[j]; }

    std::size_t size() const { return size_; }
    // The sorted geoms' records.
    const GridBox* boxes() const { return boxes_.data(); }
    const GridTag& tag(std::size_t s) const { return boxes_[s].tag; }
    GridEntry entry(std::size_t s) const {
        GridEntry e;
        aabb_from_box(boxes_[s].key, e.aabb);
        e.tag = boxes_[s].tag;
        return e;
    }
    const PrimData* prims() const { return prims_.data(); }
    std::uint64_t key(std::size_t i) const { return keys_[i]; }

    // Sorted positions [begin, end) of the geoms in cells with keys in [k0, k1].
    void range(std::uint64_t k0, std::uint64_t k1, std::uint32_t& begin, std::uint32_t& end) const {
        if (dense_) {
            begin = start_[k0];
            end = start_[k1 + 1];
        } else {
            sparse_range(k0, k1, begin, end);
        }
    }

    // Brings the cell starts range() reads for the half stencil of key k
    // towards the cache (dense table only).
    void prefetch_stencil(std::uint64_t k) const {
        if (!dense_) return;
        __builtin_prefetch(start_.data() + k);
        for (int r = 0; r < 4; ++r) __builtin_prefetch(start_.data() + k + rows_[r] - 1);
    }

    // Key offsets of the four forward rows of the half stencil; each row
    // covers the keys [k + offset - 1, k + offset + 1].
    const std::uint64_t* row_offsets() const { return rows_; }

    double cell_size() const { return h_; }

private:
    void sparse_range(std::uint64_t k0, std::uint64_t k1, std::uint32_t& begin,
                      std::uint32_t& end) const;
    void choose_cells(const CellBounds& bounds, bool empty);
    std::uint64_t cell_key(const dReal* aabb) const;
    void compute_keys(const GeomTable& infos, const std::vector<std::uint32_t>& items);
    void sort_dense(std::size_t ncells);
    void count_slabs(std::size_t tasks, std::size_t nslabs);
    void scatter_slabs(std::size_t tasks, std::size_t nslabs);
    void sort_slabs(std::size_t nslabs);
    void sort_sparse();
    void fill_entries(const GeomTable& infos, const std::vector<std::uint32_t>& items);

    double h_ = 1, inv_h_ = 1;
    double origin_[3] = {0, 0, 0};
    std::uint64_t dims_[3] = {1, 1, 1};  // padded by one cell on each side
    std::uint64_t rows_[4] = {0, 0, 0, 0};
    bool dense_ = true;
    std::vector<std::uint64_t> raw_keys_;  // per item, input order
    std::vector<std::uint32_t> order_;     // sorted position -> item position
    std::vector<std::uint32_t> start_;     // dense: cell -> first sorted position
    std::vector<std::size_t> slab_pos_;    // dense sort: per task and z-slab
    std::vector<std::size_t> slab_start_;  // dense sort: first position per slab
    std::vector<std::uint32_t> slab_items_;  // dense sort: items in slab order
    std::vector<std::uint64_t> ukeys_;     // sparse: occupied keys
    std::vector<std::uint32_t> ustart_;    // sparse: first sorted position per key
    std::vector<std::uint64_t> keys_;      // per sorted position
    std::size_t size_ = 0;
    ScratchArray<GridBox> boxes_{nullptr, kSlotEntries};
    ScratchArray<PrimData> prims_{nullptr, kSlotPrims};
};

}  // namespace parode::omp
