// METIS partition of the cell graph (see partition.hpp).
#include "partition.hpp"

#include <metis.h>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "domain/cells.hpp"

namespace parode::mpi {
namespace {

struct Graph {
    std::vector<idx_t> xadj{0}, adjncy, vwgt, adjwgt;
};

Graph build_graph(const std::vector<CellLoad>& cells) {
    Graph g;
    auto index = [&cells](std::uint64_t key) {
        const auto it = std::lower_bound(cells.begin(), cells.end(), key,
                                         [](const CellLoad& c, std::uint64_t k) { return c.key < k; });
        return it != cells.end() && it->key == key ? static_cast<long>(it - cells.begin()) : -1L;
    };
    for (const CellLoad& c : cells) {
        g.vwgt.push_back(static_cast<idx_t>(std::max<std::int64_t>(1, c.work)));
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
    return g;
}

// Fewer cells than parts, or one part: contiguous runs of keys.
std::vector<int> block_parts(std::size_t n, int parts) {
    std::vector<int> p(n);
    for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<int>(i * static_cast<std::size_t>(parts) / std::max<std::size_t>(n, 1));
    return p;
}

std::vector<int> metis_parts(Graph& g, int parts, idx_t& cut) {
    idx_t n = static_cast<idx_t>(g.vwgt.size()), ncon = 1, np = parts;
    idx_t options[METIS_NOPTIONS];
    METIS_SetDefaultOptions(options);
    options[METIS_OPTION_SEED] = 1;
    options[METIS_OPTION_NUMBERING] = 0;
    std::vector<idx_t> part(static_cast<std::size_t>(n));
    const int rc = METIS_PartGraphKway(&n, &ncon, g.xadj.data(), g.adjncy.data(), g.vwgt.data(), nullptr,
                                       g.adjwgt.data(), &np, nullptr, nullptr, options, &cut, part.data());
    if (rc != METIS_OK) throw std::runtime_error("METIS_PartGraphKway failed (code " + std::to_string(rc) + ")");
    return std::vector<int>(part.begin(), part.end());
}

}  // namespace

std::vector<CellLoad> merge_cells(std::vector<CellLoad> cells) {
    std::sort(cells.begin(), cells.end(), [](const CellLoad& a, const CellLoad& b) { return a.key < b.key; });
    std::vector<CellLoad> out;
    for (const CellLoad& c : cells) {
        if (!out.empty() && out.back().key == c.key) {
            out.back().work += c.work;
            out.back().bodies += c.bodies;
        } else {
            out.push_back(c);
        }
    }
    return out;
}

Partition partition_cells(const std::vector<CellLoad>& cells, int parts) {
    Partition p;
    for (const CellLoad& c : cells) p.keys.push_back(c.key);
    Graph g = build_graph(cells);
    idx_t cut = 0;
    p.owner = parts <= 1 || cells.size() < 4 * static_cast<std::size_t>(parts) ? block_parts(cells.size(), parts)
                                                                               : metis_parts(g, parts, cut);
    std::vector<std::int64_t> work(static_cast<std::size_t>(std::max(parts, 1)), 0);
    std::int64_t total = 0;
    for (std::size_t i = 0; i < cells.size(); ++i) {
        work[static_cast<std::size_t>(p.owner[i])] += cells[i].work;
        total += cells[i].work;
    }
    p.edge_cut = 0;
    for (std::size_t i = 0; i < cells.size(); ++i) {
        for (idx_t e = g.xadj[i]; e < g.xadj[i + 1]; ++e) {
            if (p.owner[static_cast<std::size_t>(g.adjncy[static_cast<std::size_t>(e)])] != p.owner[i]) p.edge_cut += g.adjwgt[static_cast<std::size_t>(e)];
        }
    }
    p.edge_cut /= 2;  // each cut edge seen from both ends
    const double mean = static_cast<double>(total) / static_cast<double>(work.size());
    p.imbalance = mean > 0 ? static_cast<double>(*std::max_element(work.begin(), work.end())) / mean : 1.0;
    return p;
}

namespace {

struct Overlap {
    std::int64_t work;
    int part, process;
};

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
    std::sort(o.begin(), o.end(), [](const Overlap& a, const Overlap& b) {
        return a.part != b.part ? a.part < b.part : a.process < b.process;
    });
    std::vector<Overlap> sum;
    for (const Overlap& x : o) {
        if (!sum.empty() && sum.back().part == x.part && sum.back().process == x.process) sum.back().work += x.work;
        else sum.push_back(x);
    }
    return sum;
}

}  // namespace

void keep_owners(Partition& p, const std::vector<std::vector<CellLoad>>& held, int parts) {
    std::vector<Overlap> o = overlaps(p, held);
    std::stable_sort(o.begin(), o.end(), [](const Overlap& a, const Overlap& b) { return a.work > b.work; });
    const auto n = static_cast<std::size_t>(parts);
    std::vector<int> to(n, -1);
    std::vector<char> taken(n, 0);
    for (const Overlap& x : o) {
        const auto part = static_cast<std::size_t>(x.part), process = static_cast<std::size_t>(x.process);
        if (process >= n || to[part] >= 0 || taken[process]) continue;
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
    for (int& owner : p.owner) owner = to[static_cast<std::size_t>(owner)];
}

}  // namespace parode::mpi
