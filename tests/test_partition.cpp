// The partition of cells among processes (mpi/partition, mpi/cell_map), no
// MPI needed: METIS balances a lattice of cells within 5 % and cuts fewer
// boundary bodies than slicing by key; duplicate cells from several
// processes merge; a repartition keeps parts on the processes holding them;
// every cell, mapped or not, has exactly one owner that all
// processes compute alike; a cell's holders are the owners around it, and a
// body's are those of the cells within its reach, no more.
// Trade-off: small synthetic lattices (a few thousand cells) keep METIS fast;
// the scenes' own partitions are tested through the distributed runs.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "cell_keys.hpp"
#include "cell_map.hpp"
#include "domain/cells.hpp"
#include "partition.hpp"
#include "scene/scene_file.hpp"
#include "util/split_mix.hpp"

using namespace parode;
using namespace parode::mpi;

namespace {

using parode::test::key_of;

std::vector<CellLoad> lattice(int nx, int ny, int nz) {
    std::vector<CellLoad> cells;
    for (int x = 0; x < nx; ++x)
        for (int y = 0; y < ny; ++y)
            for (int z = 0; z < nz; ++z) cells.push_back({key_of(x, y, z), 8 + 12, 8});
    return merge_cells(std::move(cells));
}

class Parts : public ::testing::TestWithParam<int> {};

TEST_P(Parts, BalancedEveryPartUsedAndBetterThanSlices) {
    const int parts = GetParam();
    const std::vector<CellLoad> cells = lattice(16, 16, 4);
    const Partition p = partition_cells(cells, parts);
    ASSERT_EQ(p.keys.size(), cells.size());
    ASSERT_EQ(p.owner.size(), cells.size());
    std::vector<long> per(static_cast<std::size_t>(parts), 0);
    for (int o : p.owner) {
        ASSERT_GE(o, 0);
        ASSERT_LT(o, parts);
        ++per[static_cast<std::size_t>(o)];
    }
    for (long n : per) EXPECT_GT(n, 0) << "every part gets cells";
    EXPECT_LE(p.imbalance, 1.05);
    // A cut through the 16 x 16 x 4 lattice between two parts crosses at
    // least a 16 x 4 face: 64 cells, each cut edge weighing 16 bodies.
    EXPECT_GE(p.edge_cut, 64 * 16);
    EXPECT_LE(p.edge_cut, static_cast<long>(parts) * 9 * 64 * 16) << "METIS keeps boundaries short";
    const Partition again = partition_cells(cells, parts);
    EXPECT_EQ(again.owner, p.owner) << "deterministic";
}

// The solver waits for the slowest rank after every colour: METIS's
// partition balances each colour's work (within 6 %), which balancing only
// each part's total leaves up to 27 % apart on this lattice.
TEST_P(Parts, EveryColoursWorkBalanced) {
    const int parts = GetParam();
    const std::vector<CellLoad> cells = lattice(16, 16, 4);
    const Partition colours = partition_cells(cells, parts, Balance::Colours, Partitioner::Metis);
    const Partition total = partition_cells(cells, parts, Balance::Total, Partitioner::Metis);
    EXPECT_LE(colours.colour_imbalance, 1.07);
    EXPECT_LE(colours.imbalance, 1.05);
    if (parts >= 3) {
        EXPECT_LT(colours.colour_imbalance, total.colour_imbalance);
    }
    EXPECT_GE(total.colour_imbalance, total.imbalance) << "a colour's largest share is at least the total's";
}

// The bisection cuts between pairs of cell layers counted from the lowest
// occupied cell: on a lattice of like cells that starts at an odd coordinate
// every part holds as many cells of each colour (pairs counted from 0 instead
// give 1.08 to 1.21), and its planar cuts cut fewer bodies than METIS's. The
// default keeps it here: its colours are better balanced.
TEST_P(Parts, BisectionBalancesEveryColourAndCutsLess) {
    const int parts = GetParam();
    std::vector<CellLoad> cells;
    for (int x = -11; x < 13; ++x)
        for (int y = -7; y < 9; ++y)
            for (int z = 0; z < 8; ++z) cells.push_back({key_of(1000 + x, 1000 + y, 1000 + z), 20, 8});  // x from 989: odd
    cells = merge_cells(std::move(cells));
    const Partition cut = partition_cells(cells, parts, Balance::Colours, Partitioner::Bisection);
    const Partition metis = partition_cells(cells, parts, Balance::Colours, Partitioner::Metis);
    EXPECT_TRUE(cut.bisection);
    EXPECT_FALSE(metis.bisection);
    // 24 x 16 x 8 like cells: every part gets exactly its share of each colour.
    EXPECT_LE(cut.imbalance, 1.0 + 1e-12);
    EXPECT_LE(cut.colour_imbalance, 1.0 + 1e-12) << "METIS: " << metis.colour_imbalance;
    EXPECT_LT(cut.edge_cut, metis.edge_cut);
    EXPECT_EQ(std::set<int>(cut.owner.begin(), cut.owner.end()).size(), static_cast<std::size_t>(parts));
    EXPECT_EQ(partition_cells(cells, parts, Balance::Colours, Partitioner::Bisection).owner, cut.owner) << "deterministic";
    const Partition best = partition_cells(cells, parts);
    EXPECT_TRUE(best.bisection);
    EXPECT_EQ(best.owner, cut.owner);
}

INSTANTIATE_TEST_SUITE_P(Counts, Parts, ::testing::Values(2, 3, 4, 8));

// The cells each process holds under `owners` (per cell of `cells`).
std::vector<std::vector<CellLoad>> held_by(const std::vector<CellLoad>& cells, const std::vector<int>& owners, int parts) {
    std::vector<std::vector<CellLoad>> held(static_cast<std::size_t>(parts));
    for (std::size_t i = 0; i < cells.size(); ++i) held[static_cast<std::size_t>(owners[i])].push_back(cells[i]);
    return held;
}

// A repartition that finds the same parts under other numbers moves nothing:
// keep_owners gives each part back the process that holds it.
TEST_P(Parts, RenumberedPartsStayWhereTheyAre) {
    const int parts = GetParam();
    const std::vector<CellLoad> cells = lattice(16, 16, 4);
    const Partition before = partition_cells(cells, parts);
    Partition after = before;
    for (int& o : after.owner) o = (o + 1) % parts;  // the same parts, numbered afresh
    ASSERT_NE(after.owner, before.owner);
    keep_owners(after, held_by(cells, before.owner, parts), parts);
    EXPECT_EQ(after.owner, before.owner);
    EXPECT_EQ(after.edge_cut, before.edge_cut);
}

// Parts that drifted: each goes to the process holding most of its work, and
// the renumbering is a permutation (every process gets one part).
TEST_P(Parts, DriftedPartsGoWhereMostOfTheirWorkIs) {
    const int parts = GetParam();
    const std::vector<CellLoad> cells = lattice(16, 16, 4);
    Partition p = partition_cells(cells, parts);
    std::vector<int> now(p.owner.size());
    for (std::size_t i = 0; i < now.size(); ++i) now[i] = (p.owner[i] + (i % 10 == 0 ? 2 : 1)) % parts;  // a tenth elsewhere
    const std::vector<int> metis = p.owner;
    keep_owners(p, held_by(cells, now, parts), parts);
    std::set<int> used(p.owner.begin(), p.owner.end());
    EXPECT_EQ(used.size(), static_cast<std::size_t>(parts));
    std::size_t stay = 0;
    for (std::size_t i = 0; i < now.size(); ++i) {
        stay += p.owner[i] == now[i];
        EXPECT_EQ(p.owner[i], (metis[i] + 1) % parts) << "cell " << i;
    }
    EXPECT_GE(stay, now.size() * 8 / 10);
}

TEST(Partition, DuplicateCellsFromSeveralProcessesMerge) {
    const std::vector<CellLoad> merged = merge_cells({{key_of(1, 0, 0), 3, 2}, {key_of(0, 0, 0), 1, 1}, {key_of(1, 0, 0), 5, 4}});
    ASSERT_EQ(merged.size(), 2u);
    EXPECT_EQ(merged[0].key, key_of(0, 0, 0));
    EXPECT_EQ(merged[1].work, 8);
    EXPECT_EQ(merged[1].bodies, 6);
}

TEST(Partition, FewerCellsThanPartsStillOwnsEveryCell) {
    const Partition p = partition_cells(lattice(2, 1, 1), 3);
    ASSERT_EQ(p.owner.size(), 2u);
    EXPECT_NE(p.owner[0], p.owner[1]);
}

CellMap two_halves() {
    // x < 5 -> rank 0, x >= 5 -> rank 1, on a 10 x 4 x 1 slab of cells.
    std::vector<CellLoad> cells = lattice(10, 4, 1);
    std::vector<std::uint64_t> keys;
    std::vector<int> owners;
    for (const CellLoad& c : cells) {
        keys.push_back(c.key);
        const int x = static_cast<int>(CellSpace::coord(c.key, 0)) - static_cast<int>(CellSpace::coord(key_of(0, 0, 0), 0));
        owners.push_back(x < 5 ? 0 : 1);
    }
    CellMap m;
    m.assign(keys, owners, 2);
    return m;
}

TEST(CellMap, MappedAndNearestOwners) {
    const CellMap m = two_halves();
    EXPECT_EQ(m.owner(key_of(0, 0, 0)), 0);
    EXPECT_EQ(m.owner(key_of(9, 3, 0)), 1);
    EXPECT_EQ(m.owner(key_of(-1, 0, 0)), 0) << "next to rank 0's cells";
    EXPECT_EQ(m.owner(key_of(12, 2, 0)), 1) << "two cells past rank 1's cells";
    EXPECT_EQ(m.owner(key_of(2, 1, 1)), 0) << "above rank 0's cells";
    const CellMap again = two_halves();
    for (int x = -12; x < 22; x += 3) EXPECT_EQ(m.owner(key_of(x, 7, -2)), again.owner(key_of(x, 7, -2))) << x;
}

TEST(CellMap, HoldersAreTheOwnersAround) {
    const CellMap m = two_halves();
    EXPECT_EQ(m.holders(key_of(1, 1, 0), CellSpace::kAllSides), (std::vector<int>{0}));
    EXPECT_EQ(m.holders(key_of(4, 1, 0), CellSpace::kAllSides), (std::vector<int>{0, 1}));
    EXPECT_EQ(m.holders(key_of(5, 1, 0), CellSpace::kAllSides), (std::vector<int>{0, 1}));
    EXPECT_EQ(m.holders(key_of(7, 1, 0), CellSpace::kAllSides), (std::vector<int>{1}));
    // Symmetry: if rank h holds a cell's bodies, the owner holds h's bodies next to it.
    for (int x = -2; x < 12; ++x) {
        const std::vector<int>& h = m.holders(key_of(x, 0, 0), CellSpace::kAllSides);
        EXPECT_TRUE(std::find(h.begin(), h.end(), m.owner(key_of(x, 0, 0))) != h.end());
    }
}

// The cache of cells met keeps every entry as it grows (from 64 slots to
// 16,384 here, each growth placing every entry again): keys that share a
// home slot (neighbouring cells), values found, absent keys not, nothing
// after clear. Red when a growth drops or misplaces entries.
TEST(CellCache, KeepsEveryEntryAsItGrows) {
    CellCache c;
    SplitMix64 rng(11);
    std::vector<std::uint64_t> keys;
    for (int i = 0; i < 12000; ++i) {
        keys.push_back(i % 2 ? key_of(i % 40, i / 40 % 20, i / 800) : rng.next() >> 4);
        if (c.find(keys.back()) != CellCache::kNone) {
            keys.pop_back();
            continue;
        }
        c.add(keys.back(), static_cast<std::uint32_t>(keys.size()));
    }
    EXPECT_EQ(c.size(), keys.size());
    for (std::size_t i = 0; i < keys.size(); ++i) ASSERT_EQ(c.find(keys[i]), i + 1) << i;
    EXPECT_EQ(c.find(key_of(41, 0, 0)), CellCache::kNone);
    c.clear();
    EXPECT_EQ(c.find(keys[0]), CellCache::kNone);
    EXPECT_EQ(c.size(), 0u);
}

// Holders asked of 720 cells (the cache grown four times), twice, and
// after a new partition: each time the list a map that never met another
// cell gives. Red when a boundary cell's 27 owners are looked up at the
// wrong index of the cache.
TEST(CellMap, CachedHoldersAreThoseOfAFreshMap) {
    CellMap m = two_halves();
    std::vector<std::vector<int>> fresh;  // per cell, from a map that met no other
    for (int round = 0; round < 2; ++round) {
        std::size_t n = 0;
        for (int x = -3; x < 13; ++x) {
            for (int y = -2; y < 7; ++y) {
                for (int z = -2; z < 3; ++z, ++n) {
                    const std::uint64_t key = key_of(x, y, z);
                    const std::uint8_t sides = static_cast<std::uint8_t>((x * 7 + y * 3 + z) & 63);
                    if (round == 0) fresh.push_back(two_halves().holders(key, sides));
                    ASSERT_EQ(m.holders(key, sides), fresh[n]) << round << ": " << x << " " << y << " " << z;
                }
            }
        }
    }
    m = two_halves();  // a new partition drops what was met
    EXPECT_EQ(m.holders(key_of(7, 1, 0), CellSpace::kAllSides), (std::vector<int>{1}));
}

// Cells and blocks around (1000, 1000, 1000): no coordinate wraps.
// A body's holders are the owners of every cell within its reach and of no
// cell beyond it on some axis: on a lattice where each cell has its own rank,
// random positions of the middle cell, for the reach of contacts alone (half
// a cell) and of magnets (more than half). Red when the sides are ignored
// (whole neighbouring cells) or the margin is dropped from the wrong side.
TEST(CellMap, BodyHoldersAreTheCellsWithinItsReach) {
    const Scene sc = load_scene_text("[scene]\nname = \"c\"\n[catoms]\ncount = 8\nradius = 0.25\n", "c");
    const CellSpace cells(sc);
    const double E = cells.edge();
    std::vector<std::uint64_t> keys;
    std::vector<int> owners;
    for (const CellLoad& c : lattice(3, 3, 3)) keys.push_back(c.key);
    for (std::size_t k = 0; k < keys.size(); ++k) owners.push_back(static_cast<int>(k));
    CellMap m;
    m.assign(keys, owners, static_cast<int>(keys.size()));
    const double lo[3] = {(static_cast<double>(CellSpace::coord(key_of(1, 1, 1), 0)) - CellSpace::kBias) * E,
                          (static_cast<double>(CellSpace::coord(key_of(1, 1, 1), 1)) - CellSpace::kBias) * E,
                          (static_cast<double>(CellSpace::coord(key_of(1, 1, 1), 2)) - CellSpace::kBias) * E};
    SplitMix64 rng(7);
    for (const double reach : {0.5 * E / (1 + 1e-9), 0.7 * E}) {
        std::size_t copies = 0;
        for (int trial = 0; trial < 2000; ++trial) {
            double x[3];
            for (int a = 0; a < 3; ++a) x[a] = lo[a] + E * (0.001 + 0.998 * rng.uniform());
            std::uint8_t sides;
            const std::uint64_t here = cells.key(x, reach, sides);
            ASSERT_EQ(here, key_of(1, 1, 1));
            ASSERT_EQ(cells.key(x), here);  // the same floor as the key alone
            const std::vector<int>& h = m.holders(here, sides);
            copies += h.size();
            for (int j = 0; j < 27; ++j) {
                const int d[3] = {j / 9 - 1, j / 3 % 3 - 1, j % 3 - 1};
                double gap2 = 0, widest = 0;  // squared distance to the cell's box; its largest axis gap
                for (int a = 0; a < 3; ++a) {
                    const double f = (x[a] - lo[a]) / E;
                    const double g = d[a] < 0 ? f * E : d[a] > 0 ? (1 - f) * E : 0.0;
                    gap2 += g * g;
                    widest = std::max(widest, g);
                }
                const std::uint64_t key = CellSpace::neighbour(key_of(1, 1, 1), d[0], d[1], d[2]);
                const bool held = std::binary_search(h.begin(), h.end(), m.owner(key));
                if (gap2 <= reach * reach) {
                    EXPECT_TRUE(held) << "cell " << j << " within reach " << reach;
                }
                if (widest > reach + 1e-3 * E) {
                    EXPECT_FALSE(held) << "cell " << j << " beyond reach " << reach;
                }
            }
        }
        // The copies a body makes: fewer than the 27 cells around it.
        EXPECT_LT(copies, 2000u * (reach < 0.6 * E ? 9 : 16)) << reach;
    }
}

std::uint64_t mid(int x, int y, int z) { return CellSpace::neighbour(key_of(0, 0, 0), 1000 + x, 1000 + y, 1000 + z); }

// The root partitions cells up to 4 million of them (about 32 million
// catoms), then blocks of 2, 4, ... cells a side, never fewer than 64 a part.
TEST(Blocks, EdgeGrowsOnlyPastFourMillionUnitsAndKeepsPartsFed) {
    EXPECT_EQ(block_edge(1000000, 2), 1);
    EXPECT_EQ(block_edge(4000000, 64), 1);
    EXPECT_EQ(block_edge(10000000, 64), 2);
    EXPECT_EQ(block_edge(100000000, 1000), 4);
    EXPECT_EQ(block_edge(100000000, 200000), 1) << "blocks of 2 would leave a part under 64";
}

// Blocks of 2 cells a side hold one cell of each colour: the colours' work
// stays apart, the totals add up.
TEST(Blocks, CoarsenKeepsEveryColoursWork) {
    std::vector<CellLoad> cells;
    for (int x = 0; x < 4; ++x)
        for (int y = 0; y < 4; ++y)
            for (int z = 0; z < 4; ++z) cells.push_back({mid(x, y, z), 20 + x, 8});
    const std::vector<CellLoad> blocks = coarsen(cells, 2);
    ASSERT_EQ(blocks.size(), 8u);
    std::int64_t work = 0;
    for (const CellLoad& b : blocks) {
        std::int64_t sum = 0;
        for (std::int64_t w : b.colour) {
            EXPECT_GT(w, 0) << "every colour in every block";
            sum += w;
        }
        EXPECT_EQ(sum, b.work);
        EXPECT_EQ(b.bodies, 8 * 8);
        work += b.work;
    }
    EXPECT_EQ(work, 64 * 20 + 16 * (0 + 1 + 2 + 3));
    const Partition p = partition_cells(blocks, 2);
    EXPECT_LE(p.colour_imbalance, 1.15);
}

// A map of blocks: a cell belongs to its block's owner; holders look at the
// blocks of the 27 cells around.
TEST(CellMap, BlocksOwnTheirCells) {
    std::vector<std::uint64_t> keys;
    std::vector<int> owners;
    for (int bx = 0; bx < 4; ++bx) {  // blocks of 2: cells x 0..7, y and z -2..3
        for (int by = -1; by <= 1; ++by) {
            for (int bz = -1; bz <= 1; ++bz) {
                keys.push_back(block_of(mid(2 * bx, 2 * by, 2 * bz), 2));
                owners.push_back(bx < 2 ? 0 : 1);
            }
        }
    }
    std::vector<std::size_t> order(keys.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
    std::vector<std::uint64_t> k;
    std::vector<int> o;
    for (std::size_t i : order) {
        k.push_back(keys[i]);
        o.push_back(owners[i]);
    }
    CellMap m;
    m.assign(k, o, 2, 2);
    EXPECT_EQ(m.owner(mid(1, 1, 1)), 0);
    EXPECT_EQ(m.owner(mid(3, 0, 1)), 0);
    EXPECT_EQ(m.owner(mid(4, 0, 0)), 1);
    EXPECT_EQ(m.owner(mid(9, 0, 0)), 1) << "the next block, empty: its nearest mapped block's owner";
    EXPECT_EQ(m.holders(mid(1, 0, 0), CellSpace::kAllSides), (std::vector<int>{0}));
    EXPECT_EQ(m.holders(mid(3, 0, 0), CellSpace::kAllSides), (std::vector<int>{0, 1}));
    EXPECT_EQ(m.holders(mid(4, 1, 1), CellSpace::kAllSides), (std::vector<int>{0, 1}));
    EXPECT_EQ(m.holders(mid(6, 0, 0), CellSpace::kAllSides), (std::vector<int>{1}));
}

}  // namespace
