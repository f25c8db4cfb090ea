// Cell census of a scene's initial state (see cell_census.hpp).
#include "domain/cell_census.hpp"

#include <algorithm>
#include <cmath>

#include "domain/cells.hpp"
#include "domain/distribution.hpp"

namespace parode {
namespace {

bool empty(const CellCensus::Box& b) { return b.hi[0] < b.lo[0] || b.hi[1] < b.lo[1] || b.hi[2] < b.lo[2]; }

CellCensus::Box intersect(CellCensus::Box a, const CellCensus::Box& b) {
    for (int k = 0; k < 3; ++k) {
        a.lo[k] = std::max(a.lo[k], b.lo[k]);
        a.hi[k] = std::min(a.hi[k], b.hi[k]);
    }
    return a;
}

bool inside(const CellCensus::Cell& c, const CellCensus::Box& b) {
    for (int k = 0; k < 3; ++k) if (c[k] < b.lo[k] || c[k] > b.hi[k]) return false;
    return true;
}

CellCensus::Box grow(CellCensus::Box b, const CellCensus::Cell& c) {
    for (int k = 0; k < 3; ++k) {
        b.lo[k] = std::min(b.lo[k], c[k]);
        b.hi[k] = std::max(b.hi[k], c[k]);
    }
    return b;
}

}  // namespace

void CellCensus::Axis::indices(std::int64_t c0, std::int64_t c1, std::int64_t& i0, std::int64_t& i1) const {
    const std::int64_t n = static_cast<std::int64_t>(first.size()) - 1;  // cells on this axis
    c0 = std::max<std::int64_t>(c0 - lo, 0);
    c1 = std::min<std::int64_t>(c1 - lo, n - 1);
    if (n <= 0 || c1 < c0) {
        i0 = i1 = 0;
        return;
    }
    i0 = first[static_cast<std::size_t>(c0)];
    i1 = first[static_cast<std::size_t>(c1 + 1)];
}

CellCensus::CellCensus(const Scene& scene)
    : scene_(scene), edge_(CellSpace(scene).edge()), reach_(halo_reach(scene)) {
    box_.lo = {0, 0, 0};
    box_.hi = {-1, -1, -1};
    const CatomBlock& c = scene.catoms;
    if (c.count > 0) {
        for (int a = 0; a < 3; ++a) axes_[static_cast<std::size_t>(a)] = lattice_axis(a);
        const std::int64_t layer = c.dims[0] * c.dims[1], n = static_cast<std::int64_t>(c.count);
        full_layers_ = n / layer;
        top_rows_ = (n % layer) / c.dims[0];
        top_rest_ = (n % layer) % c.dims[0];
        for (int a = 0; a < 3; ++a) {
            const Axis& ax = axes_[static_cast<std::size_t>(a)];
            box_.lo[a] = ax.lo;
            box_.hi[a] = ax.lo + static_cast<std::int64_t>(ax.first.size()) - 2;
        }
    }
    for (const BodySpec& b : scene.bodies) {
        const Cell cell{cell_of(b.position[0]), cell_of(b.position[1]), cell_of(b.position[2])};
        ++listed_[cell];
        box_ = empty(box_) ? Box{cell, cell} : grow(box_, cell);
    }
}

std::int64_t CellCensus::cell_of(double x) const { return static_cast<std::int64_t>(std::floor(x / edge_)); }

// The lattice coordinates as CatomBlock::position computes them, less the jitter.
double CellCensus::lattice_coord(int a, std::int64_t i) const {
    const CatomBlock& c = scene_.catoms;
    const double k = static_cast<double>(i);
    if (a < 2) return c.base[a] + (k - 0.5 * static_cast<double>(c.dims[a] - 1)) * c.spacing;
    return c.base[2] + c.proto.shape.radius + k * c.spacing;
}

CellCensus::Axis CellCensus::lattice_axis(int a) const {
    const CatomBlock& c = scene_.catoms;
    auto coord = [this, a](long i) { return lattice_coord(a, i); };
    Axis ax;
    ax.lo = cell_of(coord(0));
    for (long i = 0; i < c.dims[a]; ++i) {
        const std::int64_t cell = cell_of(coord(i)) - ax.lo;
        while (static_cast<std::int64_t>(ax.first.size()) <= cell) ax.first.push_back(i);
    }
    ax.first.push_back(c.dims[a]);
    return ax;
}

// Catoms whose lattice indices fall in the cells of `b`: full layers, then the
// full rows and the partial row of the top layer.
std::uint64_t CellCensus::lattice_count(const Box& b) const {
    if (scene_.catoms.count == 0 || empty(b)) return 0;
    std::array<std::int64_t, 6> r;
    for (int a = 0; a < 3; ++a) axes_[static_cast<std::size_t>(a)].indices(b.lo[a], b.hi[a], r[2 * a], r[2 * a + 1]);
    return lattice_count(r);
}

std::uint64_t CellCensus::lattice_count(const std::array<std::int64_t, 6>& r) const {
    const std::int64_t i0 = r[0], i1 = r[1], j0 = r[2], j1 = r[3], k0 = r[4], k1 = r[5];
    if (i1 <= i0 || j1 <= j0 || k1 <= k0) return 0;
    std::int64_t n = (i1 - i0) * (j1 - j0) * std::max<std::int64_t>(0, std::min(k1, full_layers_) - k0);
    if ((top_rows_ > 0 || top_rest_ > 0) && k0 <= full_layers_ && full_layers_ < k1) {
        n += std::max<std::int64_t>(0, std::min(j1, top_rows_) - j0) * (i1 - i0);
        if (j0 <= top_rows_ && top_rows_ < j1) n += std::max<std::int64_t>(0, std::min(i1, top_rest_) - i0);
    }
    return static_cast<std::uint64_t>(n);
}

std::uint64_t CellCensus::count(const Cell& c) const { return count(Box{c, c}); }

std::uint64_t CellCensus::count(const Box& b) const {
    if (empty(b)) return 0;
    std::uint64_t n = lattice_count(b);
    for (const auto& [cell, m] : listed_) n += inside(cell, b) ? m : 0;
    return n;
}

CellStats CellCensus::stats() const {
    CellStats s;
    s.edge = edge_;
    s.r_max = scene_.max_bounding_radius();
    s.halo = reach_;
    if (scene_.catoms.count > 0) {
        Box lattice{{axes_[0].lo, axes_[1].lo, axes_[2].lo}, {}};
        for (int a = 0; a < 3; ++a) lattice.hi[a] = lattice.lo[a] + static_cast<std::int64_t>(axes_[a].first.size()) - 2;
        Cell c;
        for (c[2] = lattice.lo[2]; c[2] <= lattice.hi[2]; ++c[2])
            for (c[1] = lattice.lo[1]; c[1] <= lattice.hi[1]; ++c[1])
                for (c[0] = lattice.lo[0]; c[0] <= lattice.hi[0]; ++c[0]) {
                    const std::uint64_t n = lattice_count(Box{c, c});
                    s.occupied += n > 0;
                    s.max_bodies = std::max(s.max_bodies, n);
                }
    }
    for (const auto& [cell, m] : listed_) {
        const std::uint64_t lattice = lattice_count(Box{cell, cell});
        s.occupied += lattice == 0;
        s.max_bodies = std::max(s.max_bodies, lattice + m);
    }
    s.mean_bodies = s.occupied ? static_cast<double>(scene_.body_count()) / static_cast<double>(s.occupied) : 0;
    return s;
}

// Lattice indices within `reach` (and the sides' margin, as CellSpace::key
// tests it) of cells [c0, c1]: from the first index at or past the lower
// bound to the first at or past the upper (coordinates rise with the index).
void CellCensus::reach_indices(int a, std::int64_t c0, std::int64_t c1, double reach, std::int64_t& i0,
                               std::int64_t& i1) const {
    const std::int64_t n = scene_.catoms.dims[a];
    const double wide = reach + CellSpace::kSideMargin * edge_;
    const double lo = static_cast<double>(c0) * edge_ - wide, hi = static_cast<double>(c1 + 1) * edge_ + wide;
    const auto first_past = [&](double x) {
        std::int64_t l = 0, h = n;
        while (l < h) {
            const std::int64_t m = l + (h - l) / 2;
            if (lattice_coord(a, m) < x) l = m + 1;
            else h = m;
        }
        return l;
    };
    i0 = first_past(lo);
    i1 = first_past(hi);
}

// Recursive bisection: the longest axis of `b` is cut where the bodies on
// either side are in proportion to the ranks on that side.
void CellCensus::split(const Box& b, int ranks, std::vector<Box>& leaves) const {
    if (ranks == 1) {
        leaves.push_back(b);
        return;
    }
    int axis = 0;
    for (int a = 1; a < 3; ++a) if (b.hi[a] - b.lo[a] > b.hi[axis] - b.lo[axis]) axis = a;
    const int left = ranks / 2;
    if (empty(b) || b.hi[axis] == b.lo[axis]) {  // one cell: the other ranks get nothing
        leaves.push_back(b);
        for (int r = 1; r < ranks; ++r) leaves.push_back(Box{{0, 0, 0}, {-1, -1, -1}});
        return;
    }
    const double target = static_cast<double>(count(b)) * left / ranks;
    auto below = [&](std::int64_t cut) {  // bodies in the cells up to `cut` on the axis
        Box part = b;
        part.hi[axis] = cut;
        return static_cast<double>(count(part));
    };
    std::int64_t lo = b.lo[axis], hi = b.hi[axis] - 1;  // the cut leaves a cell on each side
    while (lo < hi) {
        const std::int64_t mid = lo + (hi - lo) / 2;
        if (below(mid) < target) lo = mid + 1;
        else hi = mid;
    }
    if (lo > b.lo[axis] && target - below(lo - 1) < below(lo) - target) --lo;
    Box first = b, second = b;
    first.hi[axis] = lo;
    second.lo[axis] = lo + 1;
    split(first, left, leaves);
    split(second, ranks - left, leaves);
}

GhostEstimate CellCensus::ghosts(int ranks) const {
    GhostEstimate g;
    g.ranks = std::max(1, ranks);
    std::vector<Box> leaves;
    split(box_, g.ranks, leaves);
    double total = 0;
    for (const Box& leaf : leaves) {
        if (empty(leaf)) continue;
        Box halo = leaf;  // the [[bodies]]' halo: whole neighbouring cells
        for (int a = 0; a < 3; ++a) {
            --halo.lo[a];
            ++halo.hi[a];
        }
        std::array<std::int64_t, 6> near{};  // the catoms': within the reach
        for (int a = 0; a < 3; ++a) reach_indices(a, leaf.lo[a], leaf.hi[a], reach_, near[2 * a], near[2 * a + 1]);
        const double own = static_cast<double>(count(leaf));
        const double listed = static_cast<double>(count(intersect(halo, box_)) - lattice_count(intersect(halo, box_)));
        const double ghosts = static_cast<double>(scene_.catoms.count ? lattice_count(near) : 0) + listed - own;
        g.bodies_max = std::max(g.bodies_max, own);
        g.ghosts_max = std::max(g.ghosts_max, ghosts);
        total += ghosts;
    }
    g.ghosts_mean = total / g.ranks;
    g.fraction = total / static_cast<double>(std::max<std::size_t>(1, scene_.body_count()));
    return g;
}

}  // namespace parode
