// Broadphase candidates and narrowphase of the grid backend (see grid_pairs.hpp).
#include "omp/grid/grid_pairs.hpp"

#include <algorithm>

#include "omp/grid/grid_boxes.hpp"
#include "util/substages.hpp"

namespace parode::omp {
namespace {

// Candidates of sorted geom a: appended at out[n], n advanced past the
// passing ones. Grid candidates pass the AABB test only (the narrowphase
// applies the rest of the filter to the few that do); big-list ones pass all.
std::size_t collect(const PairInputs& in, const GridBox* c, std::size_t a, const Spans& sp, Candidate* out,
                    std::size_t n) {
    for (int r = 0; r < 5; ++r) n = overlap_span(c, a, sp.begin[r], sp.end[r], out, n);
    if (in.nbig == 0) return n;
    const GridEntry ea = in.grid->entry(a);
    const auto ua = static_cast<std::uint32_t>(a);
    for (std::size_t j = 0; j < in.nbig; ++j) {
        out[n] = Candidate(ua, static_cast<std::uint32_t>(j) | kBigList);
        n += passes(in, ea, in.big[j]);
    }
    return n;
}

void broadphase(const PairInputs& in, std::size_t a0, std::size_t a1, std::vector<Candidate>& cand) {
    const GridBox* c = in.grid->boxes();
    std::size_t n = 0;
    for (std::size_t a = a0; a < a1; ++a) {
        const Spans sp = spans_of(*in.grid, a);
        const std::size_t need = n + sp.total() + in.nbig + 1;  // the most candidates a can write
        if (need > cand.size()) cand.resize(std::max(need, 2 * cand.size()));
        n = collect(in, c, a, sp, cand.data(), n);
    }
    cand.resize(n);
}

// Whether grid candidate c passes the filter beyond its AABBs.
bool candidate_tags_pass(const PairInputs& in, const Candidate& c) {
    if (c.b & kBigList) return true;  // tested whole by collect
    return tags_pass(in, in.grid->tag(c.a), in.grid->tag(c.b));
}

// Sphere pairs: a run when they touch (written, kept only if so); then the
// rest: primitive pairs through dCollide, others deferred.
void narrowphase(const PairInputs& in, const std::vector<Candidate>& cand, Lane& l) {
    const PrimData* grid = in.grid->prims();
    const GridBox* box = in.grid->boxes();
    std::size_t n = l.runs.size();
    l.runs.resize(n + cand.size());
    l.others.clear();
    for (const Candidate& c : cand) {
        const PrimData& pa = grid[c.a];
        const PrimData& pb = c.b & kBigList ? in.big_prims[c.b & ~kBigList] : grid[c.b];
        if (!fast_pair(pa.flags, pb.flags)) {
            if (candidate_tags_pass(in, c)) l.others.push_back(c);
            continue;
        }
        const bool touch = (in.max_contacts >= 1) & (pa.geom != pb.geom) & candidate_tags_pass(in, c) &
                           fast_touch(pa, (pa.flags & kSphere) != 0, pb, (pb.flags & kSphere) != 0);
        const std::uint32_t tb = c.b & kBigList ? c.b : box[c.b].tag.info;
        l.runs[n] = PairRun(std::min(pa.id, pb.id), std::max(pa.id, pb.id), box[c.a].tag.info, tb);
        n += touch;
    }
    l.runs.resize(n);
    for (const Candidate& c : l.others) {
        const PrimData& pa = grid[c.a];
        const PrimData& pb = c.b & kBigList ? in.big_prims[c.b & ~kBigList] : grid[c.b];
        if (pa.flags & pb.flags & kSafe) l.generic(pa.geom, pb.geom, in.max_contacts);
        else l.deferred.push_back(DeferredPair{pa.geom, pb.geom});
    }
}

}  // namespace

void chunk_pairs(const PairInputs& in, std::size_t a0, std::size_t a1, Lane& l) {
    const double t0 = now_seconds();
    broadphase(in, a0, a1, l.candidates);
    const double t1 = now_seconds();
    narrowphase(in, l.candidates, l);
    l.broad += t1 - t0;
    l.narrow += now_seconds() - t1;
}

void big_pairs(const PairInputs& in, Lane& l) {
    for (std::size_t i = 0; i < in.nbig; ++i) {
        for (std::size_t j = i + 1; j < in.nbig; ++j) {
            const GridEntry& a = in.big[i];
            const GridEntry& b = in.big[j];
            if (!passes(in, a, b)) continue;
            const PrimData& pa = in.big_prims[i];
            const PrimData& pb = in.big_prims[j];
            const std::uint32_t fa = a.tag.flags, fb = b.tag.flags;
            if (fast_pair(fa, fb)) l.fast(pa, (fa & kSphere) != 0, pb, (fb & kSphere) != 0, in.max_contacts);
            else if (fa & fb & kSafe) l.generic(pa.geom, pb.geom, in.max_contacts);
            else l.deferred.push_back(DeferredPair{pa.geom, pb.geom});
        }
    }
}

}  // namespace parode::omp
