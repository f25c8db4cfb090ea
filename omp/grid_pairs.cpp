// Broadphase candidates and narrowphase of the grid backend (see grid_pairs.hpp).
#include "grid_pairs.hpp"

#include <algorithm>

#include "util/substages.hpp"

namespace parode::omp {
namespace {

// ODE's collideAABBs filter on two entries; bits beyond the flags from infos.
bool passes(const PairInputs& in, const GridEntry& a, const GridEntry& b) {
    const bool bits = ((a.flags | b.flags) & kWideBits) ? body_and_bits_pass(in.infos[a.info], in.infos[b.info])
                                                        : packed_bits_pass(a.flags, b.flags);
    return aabb_overlap(a.aabb, b.aabb) & !(a.body && a.body == b.body) & bits;
}

// The spans of sorted positions geom a is tested against: the later geoms of
// its cell and the next, then the four forward rows of the half stencil.
struct Spans {
    std::uint32_t begin[5], end[5];
    std::size_t total() const {
        std::size_t m = 0;
        for (int r = 0; r < 5; ++r) m += end[r] - begin[r];
        return m;
    }
};

Spans spans_of(const CellGrid& g, std::size_t a) {
    Spans s;
    const std::uint64_t k = g.key(a);
    std::uint32_t b0 = 0;
    g.range(k, k + 1, b0, s.end[0]);
    s.begin[0] = static_cast<std::uint32_t>(a) + 1;
    for (int r = 0; r < 4; ++r) {
        const std::uint64_t c = k + g.row_offsets()[r];
        g.range(c - 1, c + 1, s.begin[r + 1], s.end[r + 1]);
    }
    return s;
}

// Candidates of sorted geom a: appended at out[n], n advanced past the passing ones.
std::size_t collect(const PairInputs& in, std::size_t a, const Spans& sp, Candidate* out, std::size_t n) {
    const GridEntry* e = in.grid->entries();
    const auto ua = static_cast<std::uint32_t>(a);
    for (int r = 0; r < 5; ++r) {
        for (std::uint32_t b = sp.begin[r]; b < sp.end[r]; ++b) {
            out[n] = Candidate(ua, b);
            n += passes(in, e[a], e[b]);
        }
    }
    for (std::size_t j = 0; j < in.nbig; ++j) {
        out[n] = Candidate(ua, static_cast<std::uint32_t>(j) | kBigList);
        n += passes(in, e[a], in.big[j]);
    }
    return n;
}

void broadphase(const PairInputs& in, std::size_t a0, std::size_t a1, std::vector<Candidate>& cand) {
    std::size_t n = 0;
    for (std::size_t a = a0; a < a1; ++a) {
        const Spans sp = spans_of(*in.grid, a);
        const std::size_t need = n + sp.total() + in.nbig;  // the most candidates a can have
        if (need > cand.size()) cand.resize(std::max(need, 2 * cand.size()));
        n = collect(in, a, sp, cand.data(), n);
    }
    cand.resize(n);
}

// Sphere pairs: a run when they touch (written, kept only if so); then the
// rest: primitive pairs through dCollide, others deferred.
void narrowphase(const PairInputs& in, const std::vector<Candidate>& cand, Lane& l) {
    const PrimData* grid = in.grid->prims();
    std::size_t n = l.runs.size();
    l.runs.resize(n + cand.size());
    l.others.clear();
    for (const Candidate& c : cand) {
        const PrimData& pa = grid[c.a];
        const PrimData& pb = c.b & kBigList ? in.big_prims[c.b & ~kBigList] : grid[c.b];
        if (!fast_pair(pa.flags, pb.flags)) {
            l.others.push_back(c);
            continue;
        }
        const bool touch = (in.max_contacts >= 1) & (pa.geom != pb.geom) &
                           fast_touch(pa, (pa.flags & kSphere) != 0, pb, (pb.flags & kSphere) != 0);
        l.runs[n] = PairRun(std::min(pa.id, pb.id), std::max(pa.id, pb.id), c.a, c.b);
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
            if (fast_pair(a.flags, b.flags)) l.fast(pa, (a.flags & kSphere) != 0, pb, (b.flags & kSphere) != 0, in.max_contacts);
            else if (a.flags & b.flags & kSafe) l.generic(pa.geom, pb.geom, in.max_contacts);
            else l.deferred.push_back(DeferredPair{pa.geom, pb.geom});
        }
    }
}

}  // namespace parode::omp
