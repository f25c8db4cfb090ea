// The bisection's tree of cuts (mpi/cut_tree), no MPI needed: the tree
// assigns every cell the part that a reference bisection (sorting the cells
// of each node, kept here as it was before the tree) gives it, on lattices
// and on scattered cells of uneven work; processes simulated by threads,
// each holding some of the cells (some cells split between several, their
// work summed), build the same tree together as one process does alone;
// cells outside the occupied box get a part too, the same from every tree.
// Trade-off: a few thousand cells and up to 13 parts keep it fast; the
// scenes' partitions are tested through the distributed runs.
#include <gtest/gtest.h>

#include <algorithm>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <numeric>
#include <random>
#include <thread>

#include "cell_keys.hpp"
#include "cut_tree.hpp"
#include "domain/cells.hpp"
#include "partition.hpp"

using namespace parode;
using namespace parode::mpi;

namespace {

using parode::test::key_of;

// The reference: sort the node's cells by (pairs of layers along the
// longest axis, then along the other two, then coordinates) and cut at the
// first cell whose middle passes the low side's share of the work.
std::uint64_t coord(const CellLoad& c, int a) { return CellSpace::coord(c.key, a); }

void reference_split(const std::vector<CellLoad>& units, const Lowest& lowest, std::uint32_t* first, std::uint32_t* last,
                     int part, int parts, std::vector<int>& owner) {
    if (parts == 1 || last - first <= 1) {
        for (std::uint32_t* i = first; i != last; ++i) owner[*i] = part;
        return;
    }
    std::array<std::uint64_t, 3> lo{~0ULL, ~0ULL, ~0ULL}, hi{0, 0, 0};
    for (std::uint32_t* i = first; i != last; ++i) {
        for (int a = 0; a < 3; ++a) {
            lo[static_cast<std::size_t>(a)] = std::min(lo[static_cast<std::size_t>(a)], coord(units[*i], a));
            hi[static_cast<std::size_t>(a)] = std::max(hi[static_cast<std::size_t>(a)], coord(units[*i], a));
        }
    }
    int axis = 0;
    for (int a = 1; a < 3; ++a) {
        if (hi[static_cast<std::size_t>(a)] - lo[static_cast<std::size_t>(a)] > hi[static_cast<std::size_t>(axis)] - lo[static_cast<std::size_t>(axis)]) axis = a;
    }
    auto order = [&](const CellLoad& c) {
        const int b = (axis + 1) % 3, d = (axis + 2) % 3;
        auto pair = [&](int a) { return (coord(c, a) - lowest[static_cast<std::size_t>(a)]) >> 1; };
        return std::array<std::uint64_t, 6>{pair(axis), pair(b), pair(d), coord(c, axis), coord(c, b), coord(c, d)};
    };
    std::sort(first, last, [&](std::uint32_t x, std::uint32_t y) { return order(units[x]) < order(units[y]); });
    const int low = parts / 2;
    std::int64_t total = 0, acc = 0;
    for (std::uint32_t* i = first; i != last; ++i) total += std::max<std::int64_t>(1, units[*i].work);
    std::uint32_t* cut = first;
    while (cut != last - 1) {
        const std::int64_t w = std::max<std::int64_t>(1, units[*cut].work);
        if (parts * (2 * acc + w) > 2 * total * low) break;
        acc += w;
        ++cut;
    }
    if (cut == first) ++cut;
    reference_split(units, lowest, first, cut, part, low, owner);
    reference_split(units, lowest, cut, last, part + low, parts - low, owner);
}

std::vector<int> reference_parts(const std::vector<CellLoad>& units, int parts) {
    Lowest lowest{~0ULL, ~0ULL, ~0ULL};
    for (const CellLoad& c : units) {
        for (int a = 0; a < 3; ++a) lowest[static_cast<std::size_t>(a)] = std::min(lowest[static_cast<std::size_t>(a)], coord(c, a));
    }
    std::vector<std::uint32_t> order(units.size());
    std::iota(order.begin(), order.end(), 0u);
    std::vector<int> owner(units.size(), 0);
    reference_split(units, lowest, order.data(), order.data() + order.size(), 0, parts, owner);
    return owner;
}

// Cells of a jittered cloud: clusters and holes, work 1 to 40.
std::vector<CellLoad> scattered(unsigned seed, int n) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> c(0, 29), w(1, 40);
    std::vector<CellLoad> cells;
    for (int i = 0; i < n; ++i) {
        const int x = c(rng), y = c(rng) / 2, z = c(rng) / 3;
        const std::int64_t work = w(rng);
        cells.push_back({key_of(777 + x, 1001 + y, 500 + z), work, 1});
    }
    return merge_cells(std::move(cells));
}

std::vector<CellLoad> slab(int nx, int ny, int nz, int x0) {
    std::vector<CellLoad> cells;
    for (int x = 0; x < nx; ++x)
        for (int y = 0; y < ny; ++y)
            for (int z = 0; z < nz; ++z) cells.push_back({key_of(x0 + x, 1000 + y, 1000 + z), 20, 8});
    return merge_cells(std::move(cells));
}

// A reusable barrier for `n` threads (C++17 has none).
class Barrier {
public:
    explicit Barrier(int n) : n_(n) {}
    void arrive_and_wait() {
        std::unique_lock<std::mutex> lock(m_);
        const long gen = generation_;
        if (++waiting_ == n_) {
            waiting_ = 0;
            ++generation_;
            cv_.notify_all();
            return;
        }
        cv_.wait(lock, [&] { return generation_ != gen; });
    }

private:
    int n_, waiting_ = 0;
    long generation_ = 0;
    std::mutex m_;
    std::condition_variable cv_;
};

// Processes simulated by threads: each reduction waits for every thread,
// combines their vectors and hands every thread the result.
class Threads {
public:
    explicit Threads(int n) : n_(n), sync_(n), parts_(static_cast<std::size_t>(n)) {}
    class Member : public Reductions {
    public:
        Member(Threads& t, int me) : t_(t), me_(me) {}
        void sum(std::int64_t* v, int n) override {
            combine(v, n, [](std::int64_t a, std::int64_t b) { return a + b; });
        }
        void min(std::uint64_t* v, int n) override {
            combine(v, n, [](std::uint64_t a, std::uint64_t b) { return std::min(a, b); });
        }
        void max(std::uint64_t* v, int n) override {
            combine(v, n, [](std::uint64_t a, std::uint64_t b) { return std::max(a, b); });
        }

    private:
        template <class T, class Op>
        void combine(T* v, int n, Op op) {
            auto& mine = t_.parts_[static_cast<std::size_t>(me_)];
            mine.resize(static_cast<std::size_t>(n) * sizeof(T));
            std::memcpy(mine.data(), v, mine.size());
            t_.sync_.arrive_and_wait();
            for (int r = 0; r < t_.n_; ++r) {
                if (r == me_) continue;
                const T* other = reinterpret_cast<const T*>(t_.parts_[static_cast<std::size_t>(r)].data());
                for (int i = 0; i < n; ++i) v[i] = op(v[i], other[i]);
            }
            t_.sync_.arrive_and_wait();
        }
        Threads& t_;
        int me_;
    };
    // The tree each thread built from its own cells.
    std::vector<CutTree> build(const std::vector<std::vector<CellLoad>>& held, int parts) {
        std::vector<CutTree> trees(static_cast<std::size_t>(n_));
        std::vector<std::thread> team;
        for (int r = 0; r < n_; ++r) {
            team.emplace_back([&, r] {
                Member m(*this, r);
                trees[static_cast<std::size_t>(r)] = build_cut_tree(held[static_cast<std::size_t>(r)], parts, m);
            });
        }
        for (std::thread& t : team) t.join();
        return trees;
    }

private:
    int n_;
    Barrier sync_;
    std::vector<std::vector<char>> parts_;
};

// `cells` dealt to `n` holders: cell i to holder i mod n, and every third
// cell split, part of its work with the next holder too.
std::vector<std::vector<CellLoad>> deal(const std::vector<CellLoad>& cells, int n) {
    std::vector<std::vector<CellLoad>> held(static_cast<std::size_t>(n));
    for (std::size_t i = 0; i < cells.size(); ++i) {
        CellLoad c = cells[i];
        const auto r = i % static_cast<std::size_t>(n);
        if (i % 3 == 0 && n > 1 && c.work > 1) {
            CellLoad rest = c;
            rest.work = c.work / 2;
            c.work -= rest.work;
            held[(r + 1) % static_cast<std::size_t>(n)].push_back(rest);
        }
        held[r].push_back(c);
    }
    for (auto& h : held) h = merge_cells(std::move(h));
    return held;
}

std::vector<int> parts_of(const CutTree& t, const std::vector<CellLoad>& cells) {
    std::vector<int> p;
    for (const CellLoad& c : cells) p.push_back(t.part(c.key));
    return p;
}

// Cells around and outside the occupied ones (below the lowest, beyond the highest).
std::vector<CellLoad> around(const std::vector<CellLoad>& cells) {
    std::vector<CellLoad> out;
    for (std::size_t i = 0; i < cells.size(); i += 7) {
        for (int d : {-40, -3, 2, 33}) out.push_back({CellSpace::neighbour(cells[i].key, d, -d, d / 2), 1, 1});
    }
    return out;
}

class CutTreeParts : public ::testing::TestWithParam<int> {};

TEST_P(CutTreeParts, GivesTheReferenceBisectionsParts) {
    const int parts = GetParam();
    for (const auto& cells : {slab(24, 16, 8, 989), slab(7, 30, 5, 12), scattered(1, 3000), scattered(7, 400)}) {
        const std::vector<int> want = reference_parts(cells, parts);
        EXPECT_EQ(parts_of(bisect_tree(cells, parts), cells), want) << cells.size() << " cells";
        EXPECT_EQ(bisect_parts(cells, parts), want);
    }
}

TEST_P(CutTreeParts, ProcessesTogetherBuildTheTreeOfOne) {
    const int parts = GetParam();
    for (const auto& cells : {slab(24, 16, 8, 989), scattered(3, 3000)}) {
        const CutTree alone = bisect_tree(cells, parts);
        const std::vector<CellLoad> outside = around(cells);
        for (int processes : {1, 3, 4}) {
            Threads team(processes);
            for (const CutTree& t : team.build(deal(cells, processes), parts)) {
                EXPECT_EQ(parts_of(t, cells), parts_of(alone, cells)) << processes << " processes";
                EXPECT_EQ(parts_of(t, outside), parts_of(alone, outside)) << processes << " processes";
                EXPECT_EQ(t.nodes().size(), alone.nodes().size());
            }
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Counts, CutTreeParts, ::testing::Values(2, 3, 5, 8, 13));

TEST(CutTree, PackingKeepsTheOrder) {
    const Lowest lowest{100, 200, 300};
    std::vector<std::uint64_t> keys;
    for (int x : {100, 101, 102, 250})
        for (int y : {200, 201, 203})
            for (int z : {300, 301, 777}) keys.push_back(key_of(x - CellSpace::kBias, y - CellSpace::kBias, z - CellSpace::kBias));
    for (int axis = 0; axis < 3; ++axis) {
        for (std::uint64_t a : keys) {
            EXPECT_EQ(unpack(pack(order_of(a, axis, lowest))), order_of(a, axis, lowest));
            for (std::uint64_t b : keys) EXPECT_EQ(pack(order_of(a, axis, lowest)) < pack(order_of(b, axis, lowest)), order_of(a, axis, lowest) < order_of(b, axis, lowest));
        }
    }
}

TEST(CutTree, NoCellsOnePart) {
    Threads team(2);
    for (const CutTree& t : team.build({{}, {}}, 4)) EXPECT_EQ(t.part(key_of(1, 2, 3)), 0);
    const std::vector<CellLoad> one{{key_of(5, 5, 5), 3, 1}};
    EXPECT_EQ(bisect_tree(one, 4).part(key_of(5, 5, 5)), 0);
}

}  // namespace
