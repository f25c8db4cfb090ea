// Lanes and the canonical merge (see lanes.hpp).
// Trade-off: the counting sort needs an array as long as the largest lower id;
// when ids are sparse (largest id far above the number of runs) a comparison
// sort is used instead. Pairs reported twice (only possible through unusual
// collide2 arguments) fall back to sorting the contact records, which is what
// the reference does.
#include "lanes.hpp"

#include <algorithm>

namespace parode::omp {
namespace {

struct RunRef {
    std::uint32_t lo, hi, lane, begin, count;
};

bool run_less(const RunRef& a, const RunRef& b) {
    if (a.lo != b.lo) return a.lo < b.lo;
    return a.hi < b.hi;
}

void gather_runs(const std::vector<Lane>& lanes, std::vector<RunRef>& refs) {
    refs.clear();
    for (std::size_t l = 0; l < lanes.size(); ++l) {
        for (const PairRun& r : lanes[l].runs) {
            refs.push_back(RunRef{r.lo, r.hi, static_cast<std::uint32_t>(l), r.begin, r.count});
        }
    }
}

// Buckets hold a handful of runs (a geom's touching partners).
void insertion_sort(RunRef* first, RunRef* last) {
    for (RunRef* i = first + 1; i < last; ++i) {
        const RunRef v = *i;
        RunRef* j = i;
        for (; j > first && v.hi < (j - 1)->hi; --j) *j = *(j - 1);
        *j = v;
    }
}

// Counting sort on lo, then insertion sort by hi inside each lo bucket.
void sort_runs_by_lo(std::vector<RunRef>& refs, std::uint32_t max_lo) {
    std::vector<std::uint32_t> start(static_cast<std::size_t>(max_lo) + 2, 0);
    for (const RunRef& r : refs) ++start[r.lo + 1];
    for (std::size_t i = 1; i < start.size(); ++i) start[i] += start[i - 1];
    std::vector<RunRef> sorted(refs.size());
    std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
    for (const RunRef& r : refs) sorted[next[r.lo]++] = r;
    for (std::size_t b = 0; b + 1 < start.size(); ++b) {
        insertion_sort(sorted.data() + start[b], sorted.data() + start[b + 1]);
    }
    refs.swap(sorted);
}

void sort_runs(std::vector<RunRef>& refs) {
    std::uint32_t max_lo = 0;
    for (const RunRef& r : refs) max_lo = std::max(max_lo, r.lo);
    if (static_cast<std::size_t>(max_lo) <= 8 * refs.size() + 65536) {
        sort_runs_by_lo(refs, max_lo);
    } else {
        std::sort(refs.begin(), refs.end(), run_less);
    }
}

bool has_duplicates(const std::vector<RunRef>& refs) {
    for (std::size_t i = 1; i < refs.size(); ++i) {
        if (refs[i].lo == refs[i - 1].lo && refs[i].hi == refs[i - 1].hi) return true;
    }
    return false;
}

void copy_runs(const std::vector<Lane>& lanes, const std::vector<RunRef>& refs,
               ContactBuffer& out) {
    std::vector<std::size_t> offset(refs.size() + 1, 0);
    for (std::size_t i = 0; i < refs.size(); ++i) offset[i + 1] = offset[i] + refs[i].count;
    out.items().resize(offset.back());
    ContactRecord* dst = out.items().data();
    const RunRef* src = refs.data();
    const Lane* lane = lanes.data();
    const std::size_t* off = offset.data();
    const long n = static_cast<long>(refs.size());
#pragma omp taskloop grainsize(4096) default(none) firstprivate(dst, src, lane, off, n)
    for (long i = 0; i < n; ++i) {
        const RunRef& r = src[i];
        const ContactRecord* from = lane[r.lane].buf.items().data() + r.begin;
        std::copy(from, from + r.count, dst + off[i]);
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
    runs.push_back(PairRun{c.lo, c.hi, static_cast<std::uint32_t>(before), 1});
}

void Lane::generic(dGeomID a, dGeomID b, int max_contacts) {
    const std::size_t before = buf.size();
    const int n = buf.collide_pair(a, b, max_contacts);
    if (n <= 0) return;
    const ContactRecord& c = buf.items()[before];
    runs.push_back(PairRun{c.lo, c.hi, static_cast<std::uint32_t>(before),
                           static_cast<std::uint32_t>(n)});
}

void merge_lanes(std::vector<Lane>& lanes, ContactBuffer& out) {
    std::vector<RunRef> refs;
    gather_runs(lanes, refs);
    sort_runs(refs);
    out.clear();
    copy_runs(lanes, refs, out);
    if (has_duplicates(refs)) out.sort_canonical();
}

}  // namespace parode::omp
