// The contact solver's sweep layout on random inputs (bodies in random local
// order with random gids, random cells, random contact counts per body, as a
// distributed run presents them): bodies sorted by (cell, gid) with slot and
// order inverse to each other; every contact at one position; each listed
// cell holds contacts of one cell only, of the colour it is listed under, in
// canonical order; dense and sparse sorts agree.
// Trade-off: 300 random cases of up to 3,000 bodies, a few milliseconds, in
// place of hand-built cases that would miss the shuffled local orders MPI
// produces.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "domain/cells.hpp"
#include "solve/sweep_layout.hpp"

using namespace parode;

namespace {

const LoopRunner kSerial;  // the serial runner: the layout's order never depends on it

struct Case {
    std::vector<std::uint64_t> cell;
    std::vector<std::uint32_t> gid, owner;
    LayoutInput input() const {
        LayoutInput in;
        in.bodies = cell.size();
        in.cell = cell.data();
        in.gid = gid.data();
        in.contacts = owner.size();
        in.owner = owner.data();
        return in;
    }
};

// `span` cells per axis (a large span makes the box sparse).
Case random_case(std::mt19937& rng, std::uint64_t span) {
    Case c;
    const std::size_t n = 1 + rng() % 3000;
    std::vector<std::uint32_t> perm(n);
    std::iota(perm.begin(), perm.end(), 0u);
    std::shuffle(perm.begin(), perm.end(), rng);
    for (std::size_t i = 0; i < n; ++i) {
        c.gid.push_back(perm[i] * 3 + 7);
        std::uint64_t k = 0;
        for (int a = 0; a < 3; ++a) k |= ((std::uint64_t{1} << 19) + rng() % span) << (CellSpace::kBits * a);
        c.cell.push_back(k);
    }
    std::vector<std::uint32_t> by_gid(n);
    std::iota(by_gid.begin(), by_gid.end(), 0u);
    std::sort(by_gid.begin(), by_gid.end(), [&](std::uint32_t a, std::uint32_t b) { return c.gid[a] < c.gid[b]; });
    for (std::uint32_t b : by_gid) c.owner.insert(c.owner.end(), rng() % 4, b);  // canonical: by owner gid
    return c;
}

void check(const Case& c, const SweepLayout& L) {
    const auto& order = L.order();
    ASSERT_EQ(order.size(), c.cell.size());
    for (std::size_t s = 0; s < order.size(); ++s) {
        ASSERT_EQ(L.slot()[order[s]], s) << "slot and order are inverse";
        if (s == 0) continue;
        const std::uint32_t a = order[s - 1], b = order[s];
        ASSERT_TRUE(c.cell[a] < c.cell[b] || (c.cell[a] == c.cell[b] && c.gid[a] < c.gid[b])) << "slot " << s;
    }
    const std::size_t m = c.owner.size();
    std::vector<std::uint32_t> at(m, ~0u);
    for (std::size_t k = 0; k < m; ++k) {
        ASSERT_LT(L.position(k), m);
        ASSERT_EQ(at[L.position(k)], ~0u) << "two contacts at one position";
        at[L.position(k)] = static_cast<std::uint32_t>(k);
    }
    ASSERT_EQ(L.cells() ? L.cell_begin(L.cells()) : 0, m);
    for (int colour = 0; colour < SweepLayout::kColours; ++colour) {
        for (std::size_t t = L.colour_begin(colour); t < L.colour_end(colour); ++t) {
            const std::uint64_t key = c.cell[c.owner[at[L.cell_begin(t)]]];
            ASSERT_EQ(CellSpace::colour(key), colour);
            for (std::size_t p = L.cell_begin(t) + 1; p < L.cell_begin(t + 1); ++p) {
                ASSERT_EQ(c.cell[c.owner[at[p]]], key) << "one cell per listed cell";
                ASSERT_LT(at[p - 1], at[p]) << "canonical order within a cell";
            }
        }
    }
}

TEST(SweepLayout, RandomBodiesCellsAndContactsDense) {
    std::mt19937 rng(1);
    for (int trial = 0; trial < 200; ++trial) {
        const Case c = random_case(rng, 1 + rng() % 6);
        SweepLayout L;
        L.build(c.input(), kSerial);
        check(c, L);
        if (HasFatalFailure()) return;
    }
}

TEST(SweepLayout, SparseBoxGivesTheDenseOrder) {
    std::mt19937 rng(2);
    for (int trial = 0; trial < 100; ++trial) {
        Case c = random_case(rng, 4);
        SweepLayout dense;
        dense.build(c.input(), kSerial);
        const std::vector<std::uint32_t> order = dense.order();
        c.cell.push_back(c.cell[0] + 4000);  // one far body: more than 8 cells per body in the box
        c.gid.push_back(1u << 30);
        SweepLayout sparse;
        sparse.build(c.input(), kSerial);
        check(c, sparse);
        if (HasFatalFailure()) return;
        std::vector<std::uint32_t> without;
        for (std::uint32_t b : sparse.order()) {
            if (b + 1 != c.cell.size()) without.push_back(b);
        }
        ASSERT_EQ(without, order);
    }
}

}  // namespace
