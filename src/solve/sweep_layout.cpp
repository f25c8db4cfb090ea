// Bodies sorted by cell, cells listed by colour, contacts numbered in sweep
// order (see sweep_layout.hpp). Every pass is a loop over chunks of bodies,
// cells or contacts (util/parallel.hpp); only prefix sums over chunks are serial.
#include "solve/sweep_layout.hpp"

#include <algorithm>
#include <array>
#include <numeric>

#include "domain/cells.hpp"
#include "exec/loops.hpp"
#include "util/scratch.hpp"

namespace parode {
namespace {

constexpr std::size_t kGrain = 4096;

std::uint64_t coord(std::uint64_t key, int axis) { return CellSpace::coord(key, axis); }

}  // namespace

SweepLayout::Box SweepLayout::bounding_box(const LayoutInput& in) const {
    const LoopRunner& loops = *runner_;
    const std::size_t n = in.bodies, chunks = chunk_count(loops, n, kGrain);
    std::vector<Box> part(chunks);
    loops.run(chunks, n, [&](std::size_t c) {
        Box b;  // a local, stored once: neighbouring chunks' boxes share a cache line
        std::uint64_t hi[3] = {0, 0, 0};
        for (int a = 0; a < 3; ++a) b.lo[a] = ~0ULL;
        for (std::size_t i = chunk_begin(n, chunks, c); i < chunk_begin(n, chunks, c + 1); ++i) {
            for (int a = 0; a < 3; ++a) {
                const std::uint64_t x = coord(in.cell[i], a);
                b.lo[a] = std::min(b.lo[a], x);
                hi[a] = std::max(hi[a], x);
            }
        }
        for (int a = 0; a < 3; ++a) b.dim[a] = hi[a];  // the maximum, until combined
        part[c] = b;
    });
    Box box{};
    std::uint64_t hi[3] = {0, 0, 0};
    for (int a = 0; a < 3; ++a) box.lo[a] = ~0ULL;
    for (const Box& b : part) {
        for (int a = 0; a < 3; ++a) {
            if (b.lo[a] > b.dim[a]) continue;  // an empty chunk
            box.lo[a] = std::min(box.lo[a], b.lo[a]);
            hi[a] = std::max(hi[a], b.dim[a]);
        }
    }
    for (int a = 0; a < 3; ++a) box.dim[a] = n ? hi[a] - box.lo[a] + 1 : 1;
    if (!n) std::fill(box.lo, box.lo + 3, 0);
    return box;
}

// Stable counting sort of the bodies by box cell: into z-slabs (a histogram
// per chunk, a prefix over slabs x chunks, a scatter per chunk), then each
// slab by its cells.
void SweepLayout::sort_dense(const LayoutInput& in, const Box& box) {
    const LoopRunner& loops = *runner_;
    const std::size_t n = in.bodies, chunks = chunk_count(loops, n, kGrain);
    const std::size_t plane = box.dim[0] * box.dim[1], slabs = box.dim[2];
    lin_.resize(n);
    slab_pos_.assign(chunks * slabs, 0);
    loops.run(chunks, n, [&](std::size_t c) {
        for (std::size_t i = chunk_begin(n, chunks, c); i < chunk_begin(n, chunks, c + 1); ++i) {
            const std::uint64_t k = in.cell[i];
            const std::size_t z = coord(k, 2) - box.lo[2];
            lin_[i] = static_cast<std::uint32_t>((z * box.dim[1] + coord(k, 1) - box.lo[1]) * box.dim[0] + coord(k, 0) - box.lo[0]);
            ++slab_pos_[c * slabs + z];
        }
    });
    outer_inner_offsets(chunks, slabs, slab_pos_, slab_start_);
    slab_items_.resize(n);
    loops.run(chunks, n, [&](std::size_t c) {
        for (std::size_t i = chunk_begin(n, chunks, c); i < chunk_begin(n, chunks, c + 1); ++i) {
            slab_items_[slab_pos_[c * slabs + lin_[i] / plane]++] = static_cast<std::uint32_t>(i);
        }
    });
    count_.resize(plane * slabs);
    for_ranges(loops, slabs, 1, [&](std::size_t z0, std::size_t z1) {
        for (std::size_t z = z0; z < z1; ++z) {
            std::uint32_t* count = count_.data() + z * plane;
            std::fill(count, count + plane, 0u);
            for (std::size_t j = slab_start_[z]; j < slab_start_[z + 1]; ++j) ++count[lin_[slab_items_[j]] - z * plane];
            std::uint32_t run = static_cast<std::uint32_t>(slab_start_[z]);
            for (std::size_t c = 0; c < plane; ++c) {
                const std::uint32_t k = count[c];
                count[c] = run;
                run += k;
            }
            for (std::size_t j = slab_start_[z]; j < slab_start_[z + 1]; ++j) {
                const std::uint32_t i = slab_items_[j];
                order_[count[lin_[i] - z * plane]++] = i;
            }
        }
    });
}

void SweepLayout::sort_sparse(const LayoutInput& in) {
    std::iota(order_.begin(), order_.end(), 0u);
    std::sort(order_.begin(), order_.end(), [&](std::uint32_t a, std::uint32_t b) {
        return in.cell[a] != in.cell[b] ? in.cell[a] < in.cell[b] : a < b;
    });
}

// Cells are runs of equal keys among the sorted bodies: their first slots.
void SweepLayout::list_cells(const LayoutInput& in) {
    const LoopRunner& loops = *runner_;
    const std::size_t n = in.bodies, chunks = chunk_count(loops, n, kGrain);
    std::vector<std::size_t> first(chunks + 1, 0);
    auto starts = [&](std::size_t s) { return s == 0 || in.cell[order_[s]] != in.cell[order_[s - 1]]; };
    loops.run(chunks, n, [&](std::size_t c) {
        std::size_t count = 0;  // stored once: neighbouring chunks' entries share a cache line
        for (std::size_t s = chunk_begin(n, chunks, c); s < chunk_begin(n, chunks, c + 1); ++s) count += starts(s);
        first[c + 1] = count;
    });
    std::partial_sum(first.begin(), first.end(), first.begin());
    cell_slot_.resize(first[chunks] + 1);
    cell_slot_[first[chunks]] = static_cast<std::uint32_t>(n);
    loops.run(chunks, n, [&](std::size_t c) {
        std::size_t at = first[c];
        for (std::size_t s = chunk_begin(n, chunks, c); s < chunk_begin(n, chunks, c + 1); ++s) {
            if (starts(s)) cell_slot_[at++] = static_cast<std::uint32_t>(s);
        }
    });
}

// Within a cell, bodies by global id (local order already is, on one process).
void SweepLayout::order_within_cells(const LayoutInput& in) {
    const LoopRunner& loops = *runner_;
    const std::size_t cells = cell_slot_.size() - 1;
    for_ranges(loops, cells, kGrain / 8, [&](std::size_t t0, std::size_t t1) {
        for (std::size_t t = t0; t < t1; ++t) {
            std::uint32_t* first = order_.data() + cell_slot_[t];
            std::uint32_t* last = order_.data() + cell_slot_[t + 1];
            for (std::uint32_t* i = first + 1; i < last; ++i) {
                const std::uint32_t v = *i;
                std::uint32_t* j = i;
                for (; j > first && in.gid[v] < in.gid[*(j - 1)]; --j) *j = *(j - 1);
                *j = v;
            }
        }
    });
}

// Each body's owned contacts: one run in canonical order.
void SweepLayout::find_runs(const LayoutInput& in) {
    const LoopRunner& loops = *runner_;
    run_count_.assign(in.bodies, 0);
    run_first_.resize(in.bodies);
    const std::size_t m = in.contacts;
    for_ranges(loops, m, kGrain, [&](std::size_t k0, std::size_t k1) {
        for (std::size_t k = k0; k < k1; ++k) {
            const std::uint32_t o = in.owner[k];
            if (k > 0 && in.owner[k - 1] == o) continue;
            std::size_t e = k + 1;
            while (e < m && in.owner[e] == o) ++e;
            run_first_[o] = static_cast<std::uint32_t>(k);
            run_count_[o] = static_cast<std::uint32_t>(e - k);
        }
    });
}

// Whether cell t's contacts touch a body another process holds.
bool SweepLayout::touches_shared(const LayoutInput& in, std::size_t t) const {
    for (std::uint32_t s = cell_slot_[t]; s < cell_slot_[t + 1]; ++s) {
        const std::uint32_t b = order_[s];
        if (!run_count_[b]) continue;
        if (in.shared[b]) return true;
        for (std::uint32_t k = run_first_[b]; k < run_first_[b] + run_count_[b]; ++k) {
            const std::uint32_t o = in.other[k];
            if (o != ~0u && in.shared[o]) return true;
        }
    }
    return false;
}

// Cells with contacts, colour by colour (boundary cells first), and their
// first positions.
void SweepLayout::place_contacts(const LayoutInput& in) {
    const LoopRunner& loops = *runner_;
    const std::size_t cells = cell_slot_.size() - 1, chunks = chunk_count(loops, cells, kGrain / 8);
    const bool split = in.shared && in.other;
    std::vector<std::size_t> contacts(cells);
    boundary_.resize(cells);
    std::vector<std::size_t> per(chunks * kClasses, 0), class_first;
    // Each chunk counts into a local row and stores it once: the rows of
    // neighbouring chunks share a cache line.
    loops.run(chunks, cells, [&](std::size_t c) {
        std::array<std::size_t, kClasses> count{};
        for (std::size_t t = chunk_begin(cells, chunks, c); t < chunk_begin(cells, chunks, c + 1); ++t) {
            std::size_t k = 0;
            for (std::uint32_t s = cell_slot_[t]; s < cell_slot_[t + 1]; ++s) k += run_count_[order_[s]];
            contacts[t] = k;
            boundary_[t] = split && k && touches_shared(in, t);
            if (k) ++count[2 * static_cast<std::size_t>(colour_[t]) + (boundary_[t] ? 0 : 1)];
        }
        std::copy(count.begin(), count.end(), per.begin() + static_cast<std::ptrdiff_t>(c * kClasses));
    });
    outer_inner_offsets(chunks, kClasses, per, class_first);
    std::copy_n(class_first.begin(), kClasses + 1, class_start_.begin());
    const std::size_t tasks = class_first[kClasses];
    task_cell_.resize(tasks);
    loops.run(chunks, cells, [&](std::size_t c) {
        std::array<std::size_t, kClasses> next;
        std::copy_n(per.begin() + static_cast<std::ptrdiff_t>(c * kClasses), kClasses, next.begin());
        for (std::size_t t = chunk_begin(cells, chunks, c); t < chunk_begin(cells, chunks, c + 1); ++t) {
            const std::size_t cls = 2 * static_cast<std::size_t>(colour_[t]) + (boundary_[t] ? 0 : 1);
            if (contacts[t]) task_cell_[next[cls]++] = static_cast<std::uint32_t>(t);
        }
    });
    pos_start_.resize(tasks + 1);
    std::size_t acc = 0;
    for (std::size_t j = 0; j < tasks; ++j) {
        pos_start_[j] = acc;
        acc += contacts[task_cell_[j]];
    }
    pos_start_[tasks] = acc;
    scratch_resize(position_, acc);
    for_ranges(loops, tasks, kGrain / 8, [&](std::size_t j0, std::size_t j1) {
        for (std::size_t j = j0; j < j1; ++j) {
            std::size_t p = pos_start_[j];
            const std::uint32_t t = task_cell_[j];
            for (std::uint32_t s = cell_slot_[t]; s < cell_slot_[t + 1]; ++s) {
                const std::uint32_t b = order_[s];
                for (std::uint32_t q = 0; q < run_count_[b]; ++q) position_[run_first_[b] + q] = static_cast<std::uint32_t>(p++);
            }
        }
    });
}

void SweepLayout::build(const LayoutInput& in, const LoopRunner& loops) {
    runner_ = &loops;
    const std::size_t n = in.bodies;
    order_.resize(n);
    const Box box = bounding_box(in);
    const double cells = static_cast<double>(box.dim[0]) * static_cast<double>(box.dim[1]) * static_cast<double>(box.dim[2]);
    if (cells <= 8.0 * static_cast<double>(n) + 4096.0) sort_dense(in, box);
    else sort_sparse(in);
    list_cells(in);
    order_within_cells(in);
    slot_.resize(n);
    for_ranges(loops, n, kGrain, [&](std::size_t s0, std::size_t s1) {
        for (std::size_t s = s0; s < s1; ++s) slot_[order_[s]] = static_cast<std::uint32_t>(s);
    });
    colour_.resize(cell_slot_.size() - 1);
    for_ranges(loops, colour_.size(), kGrain, [&](std::size_t t0, std::size_t t1) {
        for (std::size_t t = t0; t < t1; ++t) colour_[t] = static_cast<std::uint8_t>(CellSpace::colour(in.cell[order_[cell_slot_[t]]]));
    });
    find_runs(in);
    place_contacts(in);
}

}  // namespace parode
