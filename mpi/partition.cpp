// METIS partition of the cell graph (see partition.hpp).
#include "partition.hpp"

#include <metis.h>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "domain/cells.hpp"

namespace parode::mpi {
namespace {

// Vertex weights, one row of kConstraints per cell: the cell's work in the
// slot of its colour (the solver waits for the slowest rank after every
// colour, so each colour's work is balanced on its own), then its bodies
// (collision, forces and integration, balanced once a step).
constexpr int kColours = 8;
constexpr int kConstraints = kColours + 1;
// Units (cells or blocks) above which the partition coarsens: METIS's graph
// on the root and every process's map stay under this many entries.
constexpr std::int64_t kMaxUnits = 4000000;
// How far a colour's work may exceed its mean on one part.
constexpr double kColourTolerance = 1.06;

struct Graph {
    std::vector<idx_t> xadj{0}, adjncy, vwgt, adjwgt;
    idx_t ncon = kConstraints;
};

}  // namespace

// A unit's work by colour: its own when given, else a cell's (all its work
// in its colour).
std::array<std::int64_t, 8> colour_work(const CellLoad& c) {
    std::array<std::int64_t, 8> w = c.colour;
    bool any = false;
    for (std::int64_t x : w) any = any || x != 0;
    if (!any) w[static_cast<std::size_t>(CellSpace::colour(c.key))] = c.work;
    return w;
}

namespace {

// A constraint no cell weighs (a colour without cells) cannot be balanced:
// METIS refuses it. Its column goes.
void drop_empty_constraints(Graph& g) {
    const std::size_t n = g.vwgt.size() / kConstraints;
    std::vector<char> keep(kConstraints, 0);
    for (std::size_t i = 0; i < n; ++i) {
        for (int k = 0; k < kConstraints; ++k) keep[static_cast<std::size_t>(k)] |= g.vwgt[i * kConstraints + static_cast<std::size_t>(k)] > 0;
    }
    std::vector<idx_t> w;
    w.reserve(g.vwgt.size());
    for (std::size_t i = 0; i < n; ++i) {
        for (int k = 0; k < kConstraints; ++k) {
            if (keep[static_cast<std::size_t>(k)]) w.push_back(g.vwgt[i * kConstraints + static_cast<std::size_t>(k)]);
        }
    }
    g.ncon = static_cast<idx_t>(std::count(keep.begin(), keep.end(), 1));
    g.vwgt.swap(w);
}

Graph build_graph(const std::vector<CellLoad>& cells, Balance balance) {
    Graph g;
    const bool colours = balance == Balance::Colours;
    auto index = [&cells](std::uint64_t key) {
        const auto it = std::lower_bound(cells.begin(), cells.end(), key,
                                         [](const CellLoad& c, std::uint64_t k) { return c.key < k; });
        return it != cells.end() && it->key == key ? static_cast<long>(it - cells.begin()) : -1L;
    };
    for (const CellLoad& c : cells) {
        const std::array<std::int64_t, 8> by_colour = colour_work(c);
        for (int k = 0; k < kConstraints; ++k) {
            const std::int64_t w = k == kColours ? std::max<std::int64_t>(1, c.bodies)
                                   : colours     ? by_colour[static_cast<std::size_t>(k)]
                                   : k == 0      ? std::max<std::int64_t>(1, c.work)
                                                 : 0;  // Total: one column of work
            g.vwgt.push_back(static_cast<idx_t>(w));
        }
        for (int x = -1; x <= 1; ++x) {
            for (int y = -1; y <= 1; ++y) {
                for (int z = -1; z <= 1; ++z) {
                    if (!x && !y && !z) continue;
                    const long j = index(CellSpace::neighbour(c.key, x, y, z));
                    if (j < 0) continue;
                    g.adjncy.push_back(static_cast<idx_t>(j));
                    g.adjwgt.push_back(static_cast<idx_t>(std::max<std::int64_t>(1, c.bodies + cells[static_cast<std::size_t>(j)].bodies)));
                }
            }
        }
        g.xadj.push_back(static_cast<idx_t>(g.adjncy.size()));
    }
    if (!colours) {  // the work column alone
        std::vector<idx_t> w;
        for (std::size_t i = 0; i < g.vwgt.size(); i += kConstraints) w.push_back(g.vwgt[i]);
        g.vwgt.swap(w);
        g.ncon = 1;
        return g;
    }
    drop_empty_constraints(g);
    return g;
}

// Fewer cells than parts, or one part: contiguous runs of keys.
std::vector<int> block_parts(std::size_t n, int parts) {
    std::vector<int> p(n);
    for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<int>(i * static_cast<std::size_t>(parts) / std::max<std::size_t>(n, 1));
    return p;
}

std::vector<int> metis_parts(Graph& g, int parts, idx_t& cut) {
    idx_t n = static_cast<idx_t>(g.xadj.size() - 1), ncon = g.ncon, np = parts;
    idx_t options[METIS_NOPTIONS];
    METIS_SetDefaultOptions(options);
    options[METIS_OPTION_SEED] = 1;
    options[METIS_OPTION_NUMBERING] = 0;
    std::vector<idx_t> part(static_cast<std::size_t>(n));
    std::vector<real_t> ub(static_cast<std::size_t>(ncon), static_cast<real_t>(1.03));
    if (ncon > 1) std::fill(ub.begin(), ub.end() - 1, static_cast<real_t>(kColourTolerance));
    const int rc = METIS_PartGraphKway(&n, &ncon, g.xadj.data(), g.adjncy.data(), g.vwgt.data(), nullptr,
                                       g.adjwgt.data(), &np, nullptr, ub.data(), options, &cut, part.data());
    if (rc != METIS_OK) throw std::runtime_error("METIS_PartGraphKway failed (code " + std::to_string(rc) + ")");
    return std::vector<int>(part.begin(), part.end());
}

}  // namespace

std::uint64_t block_of(std::uint64_t key, int edge) {
    if (edge <= 1) return key;
    std::uint64_t k = 0;
    for (int a = 0; a < 3; ++a) k |= (CellSpace::coord(key, a) / static_cast<std::uint64_t>(edge)) << (CellSpace::kBits * a);
    return k;
}

int block_edge(std::int64_t cells, int parts) {
    const std::int64_t least = std::int64_t{64} * std::max(parts, 1);  // blocks a part needs at the least
    int edge = 1;
    while (cells / (std::int64_t{edge} * edge * edge) > kMaxUnits && cells / (std::int64_t{8} * edge * edge * edge) >= least) {
        edge *= 2;
    }
    return edge;
}

std::vector<CellLoad> coarsen(const std::vector<CellLoad>& cells, int edge) {
    std::vector<CellLoad> blocks;
    blocks.reserve(cells.size());
    for (const CellLoad& c : cells) {
        CellLoad b = c;
        b.key = block_of(c.key, edge);
        b.colour = colour_work(c);
        blocks.push_back(b);
    }
    return merge_cells(std::move(blocks));
}

std::vector<CellLoad> merge_cells(std::vector<CellLoad> cells) {
    std::sort(cells.begin(), cells.end(), [](const CellLoad& a, const CellLoad& b) { return a.key < b.key; });
    std::vector<CellLoad> out;
    for (const CellLoad& c : cells) {
        if (!out.empty() && out.back().key == c.key) {
            out.back().work += c.work;
            out.back().bodies += c.bodies;
            for (std::size_t k = 0; k < c.colour.size(); ++k) out.back().colour[k] += c.colour[k];
        } else {
            out.push_back(c);
        }
    }
    return out;
}

void balance_of(const std::vector<std::int64_t>& work, const std::vector<std::int64_t>& by_colour, double& imbalance,
                double& colour_imbalance) {
    const std::size_t np = work.size();
    std::int64_t total = 0;
    for (std::int64_t w : work) total += w;
    double slowest = 0;
    for (int c = 0; c < kColours; ++c) {
        std::int64_t most = 0;
        for (std::size_t r = 0; r < np; ++r) most = std::max(most, by_colour[r * kColours + static_cast<std::size_t>(c)]);
        slowest += static_cast<double>(most);
    }
    colour_imbalance = total > 0 ? slowest * static_cast<double>(np) / static_cast<double>(total) : 1.0;
    const double mean = static_cast<double>(total) / static_cast<double>(np);
    imbalance = mean > 0 ? static_cast<double>(*std::max_element(work.begin(), work.end())) / mean : 1.0;
}

namespace {

// The figures of a partition `owner` of `cells` (graph `g`).
void measure(const std::vector<CellLoad>& cells, const Graph& g, int parts, Partition& p) {
    const std::size_t np = static_cast<std::size_t>(std::max(parts, 1));
    std::vector<std::int64_t> work(np, 0), by_colour(np * kColours, 0);
    for (std::size_t i = 0; i < cells.size(); ++i) {
        const auto part = static_cast<std::size_t>(p.owner[i]);
        const std::array<std::int64_t, 8> w = colour_work(cells[i]);
        work[part] += cells[i].work;
        for (int c = 0; c < kColours; ++c) by_colour[part * kColours + static_cast<std::size_t>(c)] += w[static_cast<std::size_t>(c)];
    }
    balance_of(work, by_colour, p.imbalance, p.colour_imbalance);
    p.edge_cut = 0;
    for (std::size_t i = 0; i < cells.size(); ++i) {
        for (idx_t e = g.xadj[i]; e < g.xadj[i + 1]; ++e) {
            if (p.owner[static_cast<std::size_t>(g.adjncy[static_cast<std::size_t>(e)])] != p.owner[i]) p.edge_cut += g.adjwgt[static_cast<std::size_t>(e)];
        }
    }
    p.edge_cut /= 2;  // each cut edge seen from both ends
}

// Too few cells for METIS: contiguous runs of keys (block_parts) instead.
bool few_cells(const std::vector<CellLoad>& cells, int parts) {
    return parts <= 1 || cells.size() < 4 * static_cast<std::size_t>(parts);
}

// The partition `owner` of `cells`, measured on `g` (any balance's graph:
// the cut reads only its edges).
Partition measured(const std::vector<CellLoad>& cells, const Graph& g, int parts, std::vector<int> owner, bool bisection) {
    Partition p;
    for (const CellLoad& c : cells) p.keys.push_back(c.key);
    p.owner = std::move(owner);
    p.bisection = bisection;
    measure(cells, g, parts, p);
    return p;
}

Partition metis_on(const std::vector<CellLoad>& cells, Graph& g, int parts) {
    idx_t cut = 0;
    return measured(cells, g, parts, few_cells(cells, parts) ? block_parts(cells.size(), parts) : metis_parts(g, parts, cut),
                    false);
}

// The better balanced colours; within 0.5 %, the smaller cut; then a.
Partition& better(Partition& a, Partition& b) {
    if (a.colour_imbalance * 1.005 < b.colour_imbalance) return a;
    if (b.colour_imbalance * 1.005 < a.colour_imbalance) return b;
    return b.edge_cut < a.edge_cut ? b : a;
}

}  // namespace

// Balance::Colours: METIS's multi-constraint answer balances every colour
// within its tolerance, but may cut more than the single-constraint one,
// which on few parts often balances the colours as well: both are made and
// the one whose colours are better balanced kept (within 0.5 %, the smaller
// cut). The bisection is a third candidate (Partitioner::Best), kept the same
// way. The single-constraint graph is built once: METIS's and the
// bisection's cuts are both measured on it. Deterministic: METIS runs with a
// fixed seed, the bisection has no choice to make.
Partition partition_cells(const std::vector<CellLoad>& cells, int parts, Balance balance, Partitioner who) {
    const bool few = few_cells(cells, parts);
    Graph total = build_graph(cells, Balance::Total);
    if (who == Partitioner::Bisection && !few) return measured(cells, total, parts, bisect_parts(cells, parts), true);
    Partition metis = metis_on(cells, total, parts);
    if (balance == Balance::Colours && !few) {  // with few cells both are the same runs of keys
        Graph by_colour = build_graph(cells, Balance::Colours);
        Partition colours = metis_on(cells, by_colour, parts);
        if (&better(metis, colours) == &colours) metis = std::move(colours);
    }
    if (who == Partitioner::Metis || few) return metis;
    Partition cut = measured(cells, total, parts, bisect_parts(cells, parts), true);
    return std::move(better(metis, cut));
}

namespace {

// Work of each (new part, current process) pair that shares cells, summed.
std::vector<Overlap> overlaps(const Partition& p, const std::vector<std::vector<CellLoad>>& held) {
    std::vector<Overlap> o;
    for (std::size_t r = 0; r < held.size(); ++r) {
        for (const CellLoad& c : held[r]) {
            const auto it = std::lower_bound(p.keys.begin(), p.keys.end(), c.key);
            if (it == p.keys.end() || *it != c.key) continue;
            o.push_back({c.work, p.owner[static_cast<std::size_t>(it - p.keys.begin())], static_cast<int>(r)});
        }
    }
    return o;
}

}  // namespace

std::vector<int> ranks_by_overlap(std::vector<Overlap> o, int parts) {
    std::sort(o.begin(), o.end(), [](const Overlap& a, const Overlap& b) {
        return a.part != b.part ? a.part < b.part : a.process < b.process;
    });
    std::vector<Overlap> sum;
    for (const Overlap& x : o) {
        if (!sum.empty() && sum.back().part == x.part && sum.back().process == x.process) sum.back().work += x.work;
        else sum.push_back(x);
    }
    std::stable_sort(sum.begin(), sum.end(), [](const Overlap& a, const Overlap& b) { return a.work > b.work; });
    const auto n = static_cast<std::size_t>(parts);
    std::vector<int> to(n, -1);
    std::vector<char> taken(n, 0);
    for (const Overlap& x : sum) {
        const auto part = static_cast<std::size_t>(x.part), process = static_cast<std::size_t>(x.process);
        if (part >= n || process >= n || to[part] >= 0 || taken[process]) continue;
        to[part] = x.process;
        taken[process] = 1;
    }
    std::size_t free = 0;
    for (std::size_t part = 0; part < n; ++part) {
        if (to[part] >= 0) continue;
        while (taken[free]) ++free;
        to[part] = static_cast<int>(free);
        taken[free] = 1;
    }
    return to;
}

void keep_owners(Partition& p, const std::vector<std::vector<CellLoad>>& held, int parts) {
    const std::vector<int> to = ranks_by_overlap(overlaps(p, held), parts);
    for (int& owner : p.owner) owner = to[static_cast<std::size_t>(owner)];
}

}  // namespace parode::mpi
