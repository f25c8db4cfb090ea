// Lanes and the canonical merge (see lanes.hpp). The merge is a parallel
// bucket sort: runs are spread over blocks of the lower-id range (a histogram
// of runs and of contacts per lane, a prefix over lanes x blocks, a scatter
// per lane); each block is then sorted by (lo, hi) and at once written out at
// its offset (stored runs copied, grid sphere runs computed in place), in one
// task, while its runs are in that thread's cache. Only the prefix sums
// (lanes x blocks entries) are serial. Lanes that already hold their runs in
// canonical order, one after the other (the neighbour list's blocks in
// World's spaces), are written out as they are, one lane per task.
// Trade-off: blocks split the id range evenly, so a scene whose ids crowd in
// one part of the range puts more work in a few blocks; that costs balance in
// the sort, never correctness. Pairs reported twice (only possible through
// unusual collide2 arguments) fall back to sorting the contact records, as the
// reference does.
#include "omp/grid/lanes.hpp"
#include "omp/grid/geom_info.hpp"
#include "omp/runtime/task_split.hpp"
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

// Blocks of 2^shift consecutive lower ids: a shift per run, not a division
// (two passes over every run take the block of each).
struct BlockMap {
    std::uint64_t blocks;
    unsigned shift;
    std::size_t of(std::uint32_t lo) const { return static_cast<std::size_t>(lo >> shift); }
};

// The largest lower id is found lane by lane in tasks (a lane holds a
// thread's share of the runs); blocks of a power-of-two width cover the ids
// up to it, at most kMaxBlocks of them and about kRunsPerBlock runs each.
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
    const std::uint64_t span = (nl ? *std::max_element(lane_max.begin(), lane_max.end()) : 0) + std::uint64_t{1};
    const std::uint64_t want = std::clamp<std::size_t>(total / kRunsPerBlock, 1, kMaxBlocks);
    unsigned shift = 0;
    while (((span - 1) >> shift) + 1 > want) ++shift;  // ids per block: 2^shift
    return BlockMap{((span - 1) >> shift) + 1, shift};
}

std::uint32_t run_contacts(std::uint32_t a, std::uint32_t b) { return a & kStored ? b : 1; }

// Per lane and block, how many runs and how many contacts they hold
// (runs[lane * blocks + block], contacts likewise).
void count_blocks(const std::vector<Lane>& lanes, const BlockMap& map, std::vector<std::size_t>& runs,
                  std::vector<std::size_t>& contacts) {
    const std::size_t nl = lanes.size(), nb = map.blocks;
    runs.assign(nl * nb, 0);
    contacts.assign(nl * nb, 0);
    const Lane* lane = lanes.data();
    std::size_t* count = runs.data();
    std::size_t* held = contacts.data();
#pragma omp taskloop grainsize(1) default(none) firstprivate(lane, count, held, nl, nb, map)
    for (std::size_t l = 0; l < nl; ++l) {
        for (const PairRun& r : lane[l].runs) {
            const std::size_t at = l * nb + map.of(r.lo);
            ++count[at];
            held[at] += run_contacts(r.a, r.b);
        }
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

// Counting sort of a block on lo (its ids span a narrow range), then by hi;
// returns where the sorted runs are (the thread's buffer `s`, or the block itself).
const RunRef* sort_block(RunRef* first, RunRef* last, BlockSort& s) {
    const std::size_t n = static_cast<std::size_t>(last - first);
    if (n < 2) return first;
    std::uint32_t lo = first->lo, hi = first->lo;
    for (const RunRef* r = first; r < last; ++r) {
        lo = std::min(lo, r->lo);
        hi = std::max(hi, r->lo);
    }
    if (hi - lo > 8 * n + 64) {
        std::sort(first, last, run_less);
        return first;
    }
    std::vector<std::uint32_t>& start = s.start;  // kept by the merge: no allocation per block
    std::vector<std::uint32_t>& next = s.next;
    std::vector<RunRef>& sorted = s.sorted;
    start.assign(hi - lo + 2, 0);
    for (const RunRef* r = first; r < last; ++r) ++start[r->lo - lo + 1];
    for (std::size_t i = 1; i < start.size(); ++i) start[i] += start[i - 1];
    sorted.resize(n);
    next.assign(start.begin(), start.end() - 1);
    for (const RunRef* r = first; r < last; ++r) sorted[next[r->lo - lo]++] = *r;
    for (std::size_t b = 0; b + 1 < start.size(); ++b) {
        insertion_sort_hi(sorted.data() + start[b], sorted.data() + start[b + 1]);
    }
    return sorted.data();
}

// Runs ahead whose geoms sort_and_write prefetches: the runs come in id order
// and name geom table entries, which in World's spaces are in id order too,
// but a run's higher id lies a row or a layer of catoms ahead, and in other
// spaces the table is in the space's order (measured, when runs named grid
// positions: a third of the merge's copy waited on the two prims).
constexpr std::size_t kAhead = 12;

void prefetch_run(std::uint32_t a, std::uint32_t b, const FastSource& fast) {
    if (a & kStored) return;
    __builtin_prefetch(&fast.prim(a));
    __builtin_prefetch(&fast.prim(b));
}

// Where the merge writes: the records, and the sides when some lane has any
// (null otherwise: every contact's sides are then -1).
struct Dest {
    ContactRecord* items;
    ContactSides* sides;
};

// Sizes `out` for n contacts (every one written afterwards) and its sides
// table for the lanes' sides, if any lane has some.
Dest size_out(const std::vector<Lane>& lanes, std::size_t n, ContactBuffer& out) {
    scratch_resize(out.items(), n, Room::Small);  // the contacts creep up step by step
    const bool sides = std::any_of(lanes.begin(), lanes.end(), [](const Lane& l) { return l.buf.has_sides(); });
    if (sides) {
        scratch_resize(out.side_table(), n);
    } else {
        out.side_table().clear();
    }
    return Dest{out.items().data(), sides ? out.side_table().data() : nullptr};
}

// A run's contacts at position `at` of `dst`; returns the next position.
std::size_t write_run(const RunRef& r, const Lane* lane, const FastSource& fast, const Dest& dst, std::size_t at) {
    if (r.a & kStored) {
        const ContactBuffer& buf = lane[r.lane].buf;
        const std::size_t from = r.a & ~kStored;
        std::copy(buf.items().data() + from, buf.items().data() + from + r.b, dst.items + at);
        if (dst.sides) {
            for (std::uint32_t k = 0; k < r.b; ++k) dst.sides[at + k] = buf.sides(from + k);
        }
        return at + r.b;
    }
    const PrimData& pa = fast.prim(r.a);
    const PrimData& pb = fast.prim(r.b);
    fast_contact(pa, (pa.flags & kSphere) != 0, pb, (pb.flags & kSphere) != 0, fast.max_contacts, dst.items[at]);
    if (dst.sides) dst.sides[at] = ContactSides{};
    return at + 1;
}

// Each block sorted and at once written out at its offset (stored runs
// copied, grid sphere runs computed in place), while its runs are still in
// this thread's cache; flags a block holding a pair twice.
void sort_and_write(const std::vector<Lane>& lanes, const FastSource& fast, MergeScratch& m, ContactBuffer& out) {
    const std::vector<std::size_t>& block_start = m.block_start;
    const std::vector<std::size_t>& offsets = m.contacts;
    std::vector<unsigned char>& rep_of = m.repeated;
    std::vector<RunRef>& refs = m.refs;
    const std::size_t nb = block_start.size() - 1;
    if (m.per_thread.size() < team_threads()) m.per_thread.resize(team_threads());
    BlockSort* sorts = m.per_thread.data();
    const Dest dst = size_out(lanes, offsets[nb], out);  // every element is written below
    rep_of.assign(nb, 0);
    const Lane* lane = lanes.data();
    RunRef* ref = refs.data();
    const std::size_t* start = block_start.data();
    const std::size_t* offset = offsets.data();
    unsigned char* rep = rep_of.data();
    const FastSource* src = &fast;
#pragma omp taskloop num_tasks(task_count(nb, 1)) default(none) firstprivate(dst, lane, ref, start, offset, rep, nb, src, sorts)
    for (std::size_t b = 0; b < nb; ++b) {
        const std::size_t n = start[b + 1] - start[b];
        const RunRef* sorted = sort_block(ref + start[b], ref + start[b + 1], sorts[thread_index()]);
        std::size_t to = offset[b];
        for (std::size_t i = 0; i < n; ++i) {
            if (i + kAhead < n) prefetch_run(sorted[i + kAhead].a, sorted[i + kAhead].b, *src);
            if (i > 0 && sorted[i].lo == sorted[i - 1].lo && sorted[i].hi == sorted[i - 1].hi) rep[b] = 1;
            to = write_run(sorted[i], lane, *src, dst, to);
        }
    }
}

// What the merge learns of a lane in one pass: whether its runs are in
// strictly increasing (lo, hi) order, its first and last, and its contacts.
struct LaneOrder {
    bool sorted = true;
    std::uint64_t first = 0, last = 0;
    std::size_t contacts = 0;
};

std::uint64_t run_key(const PairRun& r) { return std::uint64_t{r.lo} << 32 | r.hi; }

LaneOrder lane_order(const Lane& l) {
    LaneOrder o;
    const std::size_t n = l.runs.size();
    if (n == 0) return o;
    o.first = run_key(l.runs[0]);
    std::uint64_t prev = o.first;
    o.contacts = run_contacts(l.runs[0].a, l.runs[0].b);
    for (std::size_t i = 1; i < n; ++i) {
        const std::uint64_t k = run_key(l.runs[i]);
        o.sorted &= prev < k;
        o.contacts += run_contacts(l.runs[i].a, l.runs[i].b);
        prev = k;
    }
    o.last = prev;
    return o;
}

// Where each lane's contacts go if the lanes, one after the other, already
// hold their runs in canonical order (offsets, one more than lanes); false
// otherwise.
bool ordered_offsets(const std::vector<Lane>& lanes, std::vector<std::size_t>& offsets) {
    const std::size_t nl = lanes.size();
    std::vector<LaneOrder> order(nl);
    LaneOrder* out = order.data();
    const Lane* lane = lanes.data();
#pragma omp taskloop grainsize(1) default(none) firstprivate(lane, out, nl)
    for (std::size_t l = 0; l < nl; ++l) out[l] = lane_order(lane[l]);
    offsets.assign(nl + 1, 0);
    bool any = false;
    std::uint64_t prev = 0;
    for (std::size_t l = 0; l < nl; ++l) {
        offsets[l + 1] = offsets[l] + order[l].contacts;
        if (lanes[l].runs.empty()) continue;
        if (!order[l].sorted || (any && !(prev < order[l].first))) return false;
        prev = order[l].last;
        any = true;
    }
    return true;
}

// The lanes' contacts, one lane per task, at their offsets.
void write_lanes(const std::vector<Lane>& lanes, const FastSource& fast, const std::vector<std::size_t>& offsets,
                 ContactBuffer& out) {
    const std::size_t nl = lanes.size();
    const Dest dst = size_out(lanes, offsets[nl], out);  // every element is written below
    const Lane* lane = lanes.data();
    const std::size_t* offset = offsets.data();
    const FastSource* src = &fast;
#pragma omp taskloop grainsize(1) default(none) firstprivate(dst, lane, offset, src, nl)
    for (std::size_t l = 0; l < nl; ++l) {
        const std::vector<PairRun>& runs = lane[l].runs;
        const std::size_t n = runs.size();
        std::size_t to = offset[l];
        for (std::size_t i = 0; i < n; ++i) {
            const PairRun& r = runs[i];
            if (i + kAhead < n) prefetch_run(runs[i + kAhead].a, runs[i + kAhead].b, *src);
            to = write_run(RunRef(r.lo, r.hi, static_cast<std::uint32_t>(l), r.a, r.b), lane, *src, dst, to);
        }
    }
}

}  // namespace

void Lane::fast(const PrimData& a, bool a_sphere, const PrimData& b, bool b_sphere,
                int max_contacts) {
    const std::size_t before = buf.size();
    append_fast_pair(a, a_sphere, b, b_sphere, max_contacts, buf);
    if (buf.size() == before) return;
    const ContactRecord& c = buf.items()[before];
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
    for (PairRun& r : lane.runs) {
        if (r.a & kStored) continue;
        const PrimData& pa = fast.prim(r.a);
        const PrimData& pb = fast.prim(r.b);
        ContactRecord c;
        fast_contact(pa, (pa.flags & kSphere) != 0, pb, (pb.flags & kSphere) != 0, fast.max_contacts, c);
        r.a = static_cast<std::uint32_t>(lane.buf.size()) | kStored;
        r.b = 1;
        lane.buf.push(c);
    }
}

bool merge_lanes(std::vector<Lane>& lanes, const FastSource& fast, ContactBuffer& out, MergeScratch& m) {
    if (ordered_offsets(lanes, m.contacts)) {
        write_lanes(lanes, fast, m.contacts, out);
        return true;
    }
    const BlockMap map = block_map(lanes);
    count_blocks(lanes, map, m.next, m.block_contacts);
    outer_inner_offsets(lanes.size(), map.blocks, m.next, m.block_start);
    outer_inner_offsets(lanes.size(), map.blocks, m.block_contacts, m.contacts);  // contacts: where each block's go
    scratch_resize(m.refs, m.block_start.back());
    scatter_runs(lanes, map, m.next, m.refs);
    sort_and_write(lanes, fast, m, out);
    if (std::any_of(m.repeated.begin(), m.repeated.end(), [](unsigned char r) { return r != 0; })) out.sort_canonical();
    return false;
}

}  // namespace parode::omp
