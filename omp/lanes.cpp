// Lanes and the canonical merge (see lanes.hpp). The merge is a parallel
// bucket sort: runs are spread over blocks of the lower-id range (a histogram
// per lane, a prefix over lanes x blocks, a scatter per lane), each block is
// sorted by (lo, hi) on its own, then blocks are written out at their offsets
// (stored runs copied, grid sphere runs computed in place). Only the prefix
// sums (lanes x blocks entries) are serial.
// Trade-off: blocks split the id range evenly, so a scene whose ids crowd in
// one part of the range puts more work in a few blocks; that costs balance in
// the sort, never correctness. Pairs reported twice (only possible through
// unusual collide2 arguments) fall back to sorting the contact records, as the
// reference does.
#include "lanes.hpp"
#include "geom_info.hpp"
#include "task_split.hpp"
#include "util/scratch.hpp"

#include <algorithm>

namespace parode::omp {
namespace {

constexpr std::size_t kRunsPerBlock = 256;
constexpr std::size_t kMaxBlocks = 1024;

bool run_less(const RunRef& a, const RunRef& b) {
    if (a.lo != b.lo) return a.lo < b.lo;
    return a.hi < b.hi;
}

struct BlockMap {
    std::uint64_t blocks;
    std::uint64_t span;  // max lo + 1
    std::size_t of(std::uint32_t lo) const {
        return static_cast<std::size_t>(static_cast<std::uint64_t>(lo) * blocks / span);
    }
};

// The largest lower id is found lane by lane in tasks (a lane holds a
// thread's share of the runs).
BlockMap block_map(const std::vector<Lane>& lanes) {
    const std::size_t nl = lanes.size();
    std::vector<std::uint32_t> lane_max(nl, 0);
    std::uint32_t* out = lane_max.data();
    const Lane* lane = lanes.data();
#pragma omp taskloop grainsize(1) default(none) firstprivate(lane, out, nl)
    for (std::size_t l = 0; l < nl; ++l) {
        std::uint32_t m = 0;
        for (const PairRun& r : lane[l].runs) m = std::max(m, r.lo);
        out[l] = m;
    }
    std::size_t total = 0;
    for (const Lane& l : lanes) total += l.runs.size();
    const std::uint32_t max_lo = nl ? *std::max_element(lane_max.begin(), lane_max.end()) : 0;
    const std::size_t blocks = std::clamp<std::size_t>(total / kRunsPerBlock, 1, kMaxBlocks);
    return BlockMap{blocks, static_cast<std::uint64_t>(max_lo) + 1};
}

// Per lane and block, how many runs (counts[lane * blocks + block]).
void count_blocks(const std::vector<Lane>& lanes, const BlockMap& map,
                  std::vector<std::size_t>& counts) {
    const std::size_t nl = lanes.size(), nb = map.blocks;
    counts.assign(nl * nb, 0);
    const Lane* lane = lanes.data();
    std::size_t* count = counts.data();
#pragma omp taskloop grainsize(1) default(none) firstprivate(lane, count, nl, nb, map)
    for (std::size_t l = 0; l < nl; ++l) {
        for (const PairRun& r : lane[l].runs) ++count[l * nb + map.of(r.lo)];
    }
}

void scatter_runs(const std::vector<Lane>& lanes, const BlockMap& map,
                  std::vector<std::size_t>& next, std::vector<RunRef>& refs) {
    const std::size_t nl = lanes.size(), nb = map.blocks;
    const Lane* lane = lanes.data();
    std::size_t* pos = next.data();
    RunRef* out = refs.data();
#pragma omp taskloop grainsize(1) default(none) firstprivate(lane, pos, out, nl, nb, map)
    for (std::size_t l = 0; l < nl; ++l) {
        for (const PairRun& r : lane[l].runs) {
            out[pos[l * nb + map.of(r.lo)]++] = RunRef(r.lo, r.hi, static_cast<std::uint32_t>(l), r.a, r.b);
        }
    }
}

// Runs of one lower id are few (a geom's touching partners): insertion sort.
void insertion_sort_hi(RunRef* first, RunRef* last) {
    for (RunRef* i = first + 1; i < last; ++i) {
        const RunRef v = *i;
        RunRef* j = i;
        for (; j > first && v.hi < (j - 1)->hi; --j) *j = *(j - 1);
        *j = v;
    }
}

// Counting sort of a block on lo (its ids span a narrow range), then by hi.
void sort_block(RunRef* first, RunRef* last) {
    const std::size_t n = static_cast<std::size_t>(last - first);
    if (n < 2) return;
    std::uint32_t lo = first->lo, hi = first->lo;
    for (const RunRef* r = first; r < last; ++r) {
        lo = std::min(lo, r->lo);
        hi = std::max(hi, r->lo);
    }
    if (hi - lo > 8 * n + 64) {
        std::sort(first, last, run_less);
        return;
    }
    thread_local std::vector<std::uint32_t> start, next;  // reused: no allocation per block
    thread_local std::vector<RunRef> sorted;
    start.assign(hi - lo + 2, 0);
    for (const RunRef* r = first; r < last; ++r) ++start[r->lo - lo + 1];
    for (std::size_t i = 1; i < start.size(); ++i) start[i] += start[i - 1];
    sorted.resize(n);
    next.assign(start.begin(), start.end() - 1);
    for (const RunRef* r = first; r < last; ++r) sorted[next[r->lo - lo]++] = *r;
    for (std::size_t b = 0; b + 1 < start.size(); ++b) {
        insertion_sort_hi(sorted.data() + start[b], sorted.data() + start[b + 1]);
    }
    std::copy(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(n), first);
}

std::uint32_t run_contacts(const RunRef& r) { return r.a & kStored ? r.b : 1; }

// Sorts each block; records its contact count and whether a pair repeats.
void sort_blocks(const std::vector<std::size_t>& block_start, std::vector<RunRef>& refs,
                 std::vector<std::size_t>& contacts, std::vector<unsigned char>& rep_of, int& repeated) {
    const std::size_t nb = block_start.size() - 1;
    contacts.assign(nb + 1, 0);
    const std::size_t* start = block_start.data();
    RunRef* ref = refs.data();
    std::size_t* count = contacts.data();
    // One flag per block, combined after the taskloop (no task reduction: each
    // task writes only its own entries).
    rep_of.assign(nb, 0);
    unsigned char* rep = rep_of.data();
#pragma omp taskloop num_tasks(task_count(nb, 1)) default(none) firstprivate(start, ref, count, nb, rep)
    for (std::size_t b = 0; b < nb; ++b) {
        sort_block(ref + start[b], ref + start[b + 1]);
        std::size_t c = 0;
        for (std::size_t i = start[b]; i < start[b + 1]; ++i) {
            c += run_contacts(ref[i]);
            if (i > start[b] && ref[i].lo == ref[i - 1].lo && ref[i].hi == ref[i - 1].hi) rep[b] = 1;
        }
        count[b] = c;
    }
    repeated = 0;
    for (unsigned char r : rep_of) repeated = repeated || r;
}

// Runs ahead whose geoms copy_blocks prefetches: the runs come in id order,
// the geoms' prims lie in grid order, so each run's two prims are cache
// misses (measured: a third of the merge's copy waited on them).
constexpr std::size_t kAhead = 12;

void prefetch_run(const RunRef& r, const FastSource& fast) {
    if (r.a & kStored) return;
    __builtin_prefetch(&fast.prim(r.a));
    __builtin_prefetch(&fast.prim(r.b));
}

// A run's contacts at `to`; returns the end.
ContactRecord* write_run(const RunRef& r, const Lane* lane, const FastSource& fast, ContactRecord* to) {
    if (r.a & kStored) {
        const ContactRecord* from = lane[r.lane].buf.items().data() + (r.a & ~kStored);
        return std::copy(from, from + r.b, to);
    }
    const PrimData& pa = fast.prim(r.a);
    const PrimData& pb = fast.prim(r.b);
    fast_contact(pa, (pa.flags & kSphere) != 0, pb, (pb.flags & kSphere) != 0, fast.max_contacts, *to);
    return to + 1;
}

void copy_blocks(const std::vector<Lane>& lanes, const FastSource& fast, const std::vector<std::size_t>& block_start,
                 const std::vector<RunRef>& refs, std::vector<std::size_t>& contacts, ContactBuffer& out) {
    const std::size_t nb = block_start.size() - 1;
    std::size_t acc = 0;
    for (std::size_t b = 0; b < nb; ++b) {
        const std::size_t c = contacts[b];
        contacts[b] = acc;
        acc += c;
    }
    scratch_resize(out.items(), acc);  // every element is written below
    ContactRecord* dst = out.items().data();
    const Lane* lane = lanes.data();
    const RunRef* ref = refs.data();
    const std::size_t* start = block_start.data();
    const std::size_t* offset = contacts.data();
    const FastSource* src = &fast;
#pragma omp taskloop num_tasks(task_count(nb, 1)) default(none) firstprivate(dst, lane, ref, start, offset, nb, src)
    for (std::size_t b = 0; b < nb; ++b) {
        ContactRecord* to = dst + offset[b];
        const std::size_t end = start[b + 1];
        for (std::size_t i = start[b]; i < end; ++i) {
            if (i + kAhead < end) prefetch_run(ref[i + kAhead], *src);
            to = write_run(ref[i], lane, *src, to);
        }
    }
}

}  // namespace

void Lane::fast(const PrimData& a, bool a_sphere, const PrimData& b, bool b_sphere,
                int max_contacts) {
    std::vector<ContactRecord>& items = buf.items();
    const std::size_t before = items.size();
    append_fast_pair(a, a_sphere, b, b_sphere, max_contacts, items);
    if (items.size() == before) return;
    const ContactRecord& c = items[before];
    runs.push_back(PairRun(c.lo, c.hi, static_cast<std::uint32_t>(before) | kStored, 1));
}

void Lane::generic(dGeomID a, dGeomID b, int max_contacts) {
    const std::size_t before = buf.size();
    const int n = buf.collide_pair(a, b, max_contacts);
    if (n <= 0) return;
    const ContactRecord& c = buf.items()[before];
    runs.push_back(PairRun(c.lo, c.hi, static_cast<std::uint32_t>(before) | kStored, static_cast<std::uint32_t>(n)));
}

void store_fast_runs(Lane& lane, const FastSource& fast) {
    std::vector<ContactRecord>& items = lane.buf.items();
    for (PairRun& r : lane.runs) {
        if (r.a & kStored) continue;
        const PrimData& pa = fast.prim(r.a);
        const PrimData& pb = fast.prim(r.b);
        ContactRecord c;
        fast_contact(pa, (pa.flags & kSphere) != 0, pb, (pb.flags & kSphere) != 0, fast.max_contacts, c);
        r.a = static_cast<std::uint32_t>(items.size()) | kStored;
        r.b = 1;
        items.push_back(c);
    }
}

void merge_lanes(std::vector<Lane>& lanes, const FastSource& fast, ContactBuffer& out, MergeScratch& m) {
    const BlockMap map = block_map(lanes);
    count_blocks(lanes, map, m.next);
    outer_inner_offsets(lanes.size(), map.blocks, m.next, m.block_start);
    scratch_resize(m.refs, m.block_start.back());
    scatter_runs(lanes, map, m.next, m.refs);
    int repeated = 0;
    sort_blocks(m.block_start, m.refs, m.contacts, m.repeated, repeated);
    copy_blocks(lanes, fast, m.block_start, m.refs, m.contacts, out);
    if (repeated) out.sort_canonical();
}

}  // namespace parode::omp
