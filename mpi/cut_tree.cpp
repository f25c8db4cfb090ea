// The bisection's tree of cuts and its collective construction (see cut_tree.hpp).
#include "cut_tree.hpp"

#include <algorithm>

#include "domain/cells.hpp"

namespace parode::mpi {

Order order_of(std::uint64_t key, int axis, const Lowest& lowest) {
    std::int64_t rel[3];
    for (int a = 0; a < 3; ++a) {
        rel[a] = static_cast<std::int64_t>(CellSpace::coord(key, a)) - static_cast<std::int64_t>(lowest[static_cast<std::size_t>(a)]);
    }
    const int b = (axis + 1) % 3, d = (axis + 2) % 3;
    // rel = 2 pair + parity, pair rounded down also below `lowest`
    return {rel[axis] >> 1, rel[b] >> 1, rel[d] >> 1, rel[axis] & 1, rel[b] & 1, rel[d] & 1};
}

std::uint64_t pack(const Order& o) {
    auto u = [&o](int i) { return static_cast<std::uint64_t>(o[static_cast<std::size_t>(i)]); };
    return u(0) << 41 | u(1) << 22 | u(2) << 3 | u(3) << 2 | u(4) << 1 | u(5);
}

Order unpack(std::uint64_t p) {
    constexpr std::uint64_t kPair = (std::uint64_t{1} << 19) - 1;
    auto s = [](std::uint64_t v) { return static_cast<std::int64_t>(v); };
    return {s((p >> 41) & kPair), s((p >> 22) & kPair), s((p >> 3) & kPair), s((p >> 2) & 1), s((p >> 1) & 1), s(p & 1)};
}

int CutTree::part(std::uint64_t key) const {
    if (nodes_.empty()) return 0;
    const CutNode* n = &nodes_[0];
    while (n->axis >= 0) n = &nodes_[static_cast<std::size_t>(order_of(key, n->axis, lowest_) < n->cut ? n->low : n->high)];
    return n->part;
}

namespace {

constexpr int kBins = 256;  // the radix descent's digit: 8 bits, 8 digits of a packed order
constexpr std::uint64_t kNone = ~0ULL;

std::int64_t weight(const CellLoad& c) { return std::max<std::int64_t>(1, c.work); }

// The bits of `key` above the digit at `shift` (none above the top digit).
std::uint64_t above(std::uint64_t key, int shift) { return shift + 8 >= 64 ? 0 : key >> (shift + 8); }

// One level of the tree: the nodes still to cut (index into `nodes`), and
// for each its longest axis, key range and work, all global.
struct Level {
    std::vector<int> node;
    std::vector<int> axis;
    std::vector<std::uint64_t> first, last;
    std::vector<std::int64_t> total;
    std::vector<int> slot;  // node -> index into this level, -1 when not cut here
    std::size_t size() const { return node.size(); }
};

// Longest axis of each node's units (the lowest on a tie), from the
// coordinates' global bounds.
void find_axes(const std::vector<CellLoad>& units, const std::vector<int>& at, Level& lv, Reductions& reduce) {
    const std::size_t n = lv.size();
    std::vector<std::uint64_t> lo(3 * n, kNone), hi(3 * n, 0);
    for (std::size_t u = 0; u < units.size(); ++u) {
        const int j = lv.slot[static_cast<std::size_t>(at[u])];
        if (j < 0) continue;
        for (int a = 0; a < 3; ++a) {
            const std::size_t i = 3 * static_cast<std::size_t>(j) + static_cast<std::size_t>(a);
            lo[i] = std::min(lo[i], CellSpace::coord(units[u].key, a));
            hi[i] = std::max(hi[i], CellSpace::coord(units[u].key, a));
        }
    }
    reduce.min(lo.data(), static_cast<int>(lo.size()));
    reduce.max(hi.data(), static_cast<int>(hi.size()));
    lv.axis.assign(n, 0);
    for (std::size_t j = 0; j < n; ++j) {
        for (int a = 1; a < 3; ++a) {
            const std::size_t i = 3 * j + static_cast<std::size_t>(a), best = 3 * j + static_cast<std::size_t>(lv.axis[j]);
            if (lo[i] != kNone && hi[i] - lo[i] > hi[best] - lo[best]) lv.axis[j] = a;
        }
    }
}

// The global first and last packed order and the total work of each node.
void find_ranges(const std::vector<std::uint64_t>& key, const std::vector<CellLoad>& units, const std::vector<int>& at,
                 Level& lv, Reductions& reduce) {
    const std::size_t n = lv.size();
    lv.first.assign(n, kNone);
    lv.last.assign(n, 0);
    lv.total.assign(n, 0);
    for (std::size_t u = 0; u < units.size(); ++u) {
        const int j = lv.slot[static_cast<std::size_t>(at[u])];
        if (j < 0) continue;
        const auto i = static_cast<std::size_t>(j);
        lv.first[i] = std::min(lv.first[i], key[u]);
        lv.last[i] = std::max(lv.last[i], key[u]);
        lv.total[i] += weight(units[u]);
    }
    reduce.min(lv.first.data(), static_cast<int>(n));
    reduce.max(lv.last.data(), static_cast<int>(n));
    reduce.sum(lv.total.data(), static_cast<int>(n));
}

struct Median {
    std::vector<std::uint64_t> unit;  // the first unit whose end passes the node's target
    std::vector<std::int64_t> before, work;  // the work before it, its own
};

// For each node (parts p, low = p / 2 of them on the low side), the first
// unit in order whose end (work up to and including it) passes total low /
// p: a radix descent over the packed order, one histogram of work a digit.
Median weighted_median(const std::vector<std::uint64_t>& key, const std::vector<CellLoad>& units,
                       const std::vector<int>& at, const Level& lv, const std::vector<CutNode>& nodes, Reductions& reduce) {
    const std::size_t n = lv.size();
    Median m{std::vector<std::uint64_t>(n, 0), std::vector<std::int64_t>(n, 0), std::vector<std::int64_t>(n, 0)};
    for (int shift = 56; shift >= 0; shift -= 8) {
        std::vector<std::int64_t> hist(n * kBins, 0);
        for (std::size_t u = 0; u < units.size(); ++u) {
            const int j = lv.slot[static_cast<std::size_t>(at[u])];
            if (j < 0 || above(key[u], shift) != m.unit[static_cast<std::size_t>(j)]) continue;
            hist[static_cast<std::size_t>(j) * kBins + ((key[u] >> shift) & (kBins - 1))] += weight(units[u]);
        }
        reduce.sum(hist.data(), static_cast<int>(hist.size()));
        for (std::size_t j = 0; j < n; ++j) {
            const CutNode& node = nodes[static_cast<std::size_t>(lv.node[j])];
            const std::int64_t p = node.parts, goal = lv.total[j] * (p / 2);
            std::int64_t cum = 0;
            std::size_t b = 0;
            for (; b + 1 < kBins; ++b) {
                const std::int64_t w = hist[j * kBins + b];
                if (w > 0 && p * (m.before[j] + cum + w) > goal) break;
                cum += w;
            }
            m.before[j] += cum;
            m.work[j] = hist[j * kBins + b];
            m.unit[j] = (m.unit[j] << 8) | b;
        }
    }
    return m;
}

// Where each node is cut, as bisect_parts's serial scan decides: at the
// first unit whose middle passes the target, never before the second unit
// nor after the last.
std::vector<std::uint64_t> cuts(const std::vector<std::uint64_t>& key, const std::vector<int>& at, const Level& lv,
                                const Median& m, const std::vector<CutNode>& nodes, Reductions& reduce) {
    const std::size_t n = lv.size();
    std::vector<std::uint64_t> next(2 * n, kNone);  // the unit after the median, after the first
    for (std::size_t u = 0; u < key.size(); ++u) {
        const int j = lv.slot[static_cast<std::size_t>(at[u])];
        if (j < 0) continue;
        const auto i = static_cast<std::size_t>(j);
        if (key[u] > m.unit[i]) next[2 * i] = std::min(next[2 * i], key[u]);
        if (key[u] > lv.first[i]) next[2 * i + 1] = std::min(next[2 * i + 1], key[u]);
    }
    reduce.min(next.data(), static_cast<int>(next.size()));
    std::vector<std::uint64_t> cut(n);
    for (std::size_t j = 0; j < n; ++j) {
        const std::int64_t p = nodes[static_cast<std::size_t>(lv.node[j])].parts;
        const bool middle_passes = p * (2 * m.before[j] + m.work[j]) > 2 * lv.total[j] * (p / 2);
        cut[j] = std::min(middle_passes ? m.unit[j] : next[2 * j], lv.last[j]);
        if (cut[j] == lv.first[j]) cut[j] = next[2 * j + 1];
    }
    return cut;
}

}  // namespace

CutTree build_cut_tree(const std::vector<CellLoad>& units, int parts, Reductions& reduce) {
    Lowest lowest{kNone, kNone, kNone};
    for (const CellLoad& c : units) {
        for (int a = 0; a < 3; ++a) lowest[static_cast<std::size_t>(a)] = std::min(lowest[static_cast<std::size_t>(a)], CellSpace::coord(c.key, a));
    }
    reduce.min(lowest.data(), 3);
    std::vector<CutNode> nodes(1);
    nodes[0].parts = std::max(parts, 1);
    std::vector<int> at(units.size(), 0);  // each unit's node
    std::vector<int> todo;
    if (nodes[0].parts > 1 && lowest[0] != kNone) todo.push_back(0);
    std::vector<std::uint64_t> key(units.size());
    while (!todo.empty()) {
        Level lv;
        lv.node = todo;
        lv.slot.assign(nodes.size(), -1);
        for (std::size_t j = 0; j < todo.size(); ++j) lv.slot[static_cast<std::size_t>(todo[j])] = static_cast<int>(j);
        find_axes(units, at, lv, reduce);
        for (std::size_t u = 0; u < units.size(); ++u) {
            const int j = lv.slot[static_cast<std::size_t>(at[u])];
            if (j >= 0) key[u] = pack(order_of(units[u].key, lv.axis[static_cast<std::size_t>(j)], lowest));
        }
        find_ranges(key, units, at, lv, reduce);
        const Median m = weighted_median(key, units, at, lv, nodes, reduce);
        const std::vector<std::uint64_t> cut = cuts(key, at, lv, m, nodes, reduce);
        todo.clear();
        for (std::size_t j = 0; j < lv.size(); ++j) {
            const auto id = static_cast<std::size_t>(lv.node[j]);
            if (lv.first[j] >= lv.last[j]) continue;  // one cell (or none): a leaf
            const CutNode parent = nodes[id];
            const int low = parent.parts / 2;
            CutNode lo, hi;
            lo.part = parent.part;
            lo.parts = low;
            hi.part = parent.part + low;
            hi.parts = parent.parts - low;
            nodes[id].axis = lv.axis[j];
            nodes[id].cut = unpack(cut[j]);
            nodes[id].low = static_cast<int>(nodes.size());
            nodes[id].high = static_cast<int>(nodes.size() + 1);
            nodes.push_back(lo);
            nodes.push_back(hi);
            if (lo.parts > 1) todo.push_back(nodes[id].low);
            if (hi.parts > 1) todo.push_back(nodes[id].high);
        }
        for (std::size_t u = 0; u < units.size(); ++u) {
            const auto n = static_cast<std::size_t>(at[u]);
            if (n >= lv.slot.size() || lv.slot[n] < 0 || nodes[n].axis < 0) continue;
            at[u] = key[u] < cut[static_cast<std::size_t>(lv.slot[n])] ? nodes[n].low : nodes[n].high;
        }
    }
    return CutTree(lowest, std::move(nodes));
}

namespace {

// The reductions of one process alone: every value is already global.
class Alone : public Reductions {
public:
    void sum(std::int64_t*, int) override {}
    void min(std::uint64_t*, int) override {}
    void max(std::uint64_t*, int) override {}
};

}  // namespace

CutTree bisect_tree(const std::vector<CellLoad>& units, int parts) {
    Alone alone;
    return build_cut_tree(units, parts, alone);
}

std::vector<int> bisect_parts(const std::vector<CellLoad>& units, int parts) {
    const CutTree tree = bisect_tree(units, parts);
    std::vector<int> owner(units.size());
    for (std::size_t i = 0; i < units.size(); ++i) owner[i] = tree.part(units[i].key);
    return owner;
}

}  // namespace parode::mpi
