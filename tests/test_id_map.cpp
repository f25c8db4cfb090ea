// IdMap against std::map on the same random sequence of sets, updates and
// erasures: the dense table and the paged one give every lookup the
// reference gives, through growth and through erasures that empty pages and
// shift the directory's runs back (ids of a wide range in a few slots, so
// runs are long and wrap around the table's end); pages are given back and
// reused; and which form a share of the ids gets. GidTable (the
// objects held by id, over an IdMap) against std::map the same way.
// Trade-off: a fixed seed and sizes of a few thousand ids: every branch of
// the shifting is taken many times, in milliseconds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <vector>

#include "util/gid_table.hpp"
#include "util/id_map.hpp"

using namespace parode;

namespace {

// Random operations on ids ids[0..n) (ids[i] = i without a list), checked
// after every one.
void churn(IdMap& m, std::uint32_t range, int ops, const std::vector<std::uint32_t>* ids = nullptr,
           unsigned seed = 12345) {
    std::map<std::uint32_t, std::uint32_t> ref;
    std::mt19937 rng(seed);
    const auto pick = [&](std::uint32_t r) { return ids ? (*ids)[r] : r; };
    for (int op = 0; op < ops; ++op) {
        const std::uint32_t id = pick(rng() % range);
        if (rng() % 3 == 0) {
            m.erase(id);
            ref.erase(id);
        } else {
            const std::uint32_t local = rng() % 1000000;
            m.set(id, local);
            ref[id] = local;
        }
        const std::uint32_t probe = pick(rng() % range);
        const auto it = ref.find(probe);
        ASSERT_EQ(m.find(probe), it == ref.end() ? IdMap::kNone : it->second) << "op " << op << " id " << probe;
    }
    for (std::uint32_t r = 0; r < range; ++r) {
        const std::uint32_t id = pick(r);
        const auto it = ref.find(id);
        ASSERT_EQ(m.find(id), it == ref.end() ? IdMap::kNone : it->second) << "id " << id;
    }
}

TEST(IdMap, DenseForMostOfTheRangePagedForAShare) {
    IdMap whole, half, eighth;
    whole.reset(100000, 100000);
    half.reset(100000, 50000);
    eighth.reset(800000, 100000);
    EXPECT_TRUE(whole.dense());
    EXPECT_TRUE(half.dense());
    EXPECT_FALSE(eighth.dense());
}

TEST(IdMap, DenseTableAgreesWithAMap) {
    IdMap m;
    m.reset(3000, 3000);
    ASSERT_TRUE(m.dense());
    churn(m, 3000, 20000);
}

TEST(IdMap, PagedAgreesWithAMapThroughGrowthAndErasures) {
    IdMap m;
    m.reset(1u << 30, 16);  // starts small: grows many times
    ASSERT_FALSE(m.dense());
    churn(m, 5000, 40000);
}

TEST(IdMap, DirectoryRunsThatWrapAroundShiftBack) {
    // 16 slots, 7 ids of a wide range: over 400 such sets, runs that wrap
    // past the last slot form and are shifted back many times.
    std::mt19937 rng(7);
    for (unsigned set = 0; set < 400; ++set) {
        std::vector<std::uint32_t> ids(7);
        for (std::uint32_t& id : ids) id = rng() % (1u << 31);
        IdMap m;
        m.reset(1u << 31, 4);
        ASSERT_FALSE(m.dense());
        churn(m, 7, 200, &ids, set);
    }
}

// A rank's share: rows of 100 ids every 1,000 (catoms of its blocks), set,
// half erased, set again: the pages in use are the pages the ids touch, and
// a page emptied is reused rather than added.
TEST(IdMap, PagedTableHoldsTheRowsPagesAndReusesThem) {
    IdMap m;
    m.reset(1000000, 10000);
    ASSERT_FALSE(m.dense());
    std::vector<std::uint32_t> ids;
    for (std::uint32_t row = 0; row < 100; ++row) {
        for (std::uint32_t k = 0; k < 100; ++k) ids.push_back(row * 1000 + 7 + k);
    }
    const auto pages_of = [&ids](std::size_t from, std::size_t to) {
        std::vector<std::uint32_t> p;
        for (std::size_t i = from; i < to; ++i) p.push_back(ids[i] / IdMap::kPage);
        std::sort(p.begin(), p.end());
        return static_cast<std::size_t>(std::unique(p.begin(), p.end()) - p.begin());
    };
    for (std::size_t i = 0; i < ids.size(); ++i) m.set(ids[i], static_cast<std::uint32_t>(i));
    EXPECT_EQ(m.pages(), pages_of(0, ids.size()));
    for (std::size_t i = 0; i < ids.size() / 2; ++i) m.erase(ids[i]);  // the first 50 rows
    EXPECT_EQ(m.pages(), pages_of(ids.size() / 2, ids.size()));
    for (std::size_t i = 0; i < ids.size(); ++i) {
        ASSERT_EQ(m.find(ids[i]), i < ids.size() / 2 ? IdMap::kNone : i) << ids[i];
    }
    for (std::size_t i = 0; i < ids.size() / 2; ++i) m.set(ids[i] + 500, static_cast<std::uint32_t>(i));
    EXPECT_EQ(m.find(ids[0] + 500), 0u);
    EXPECT_EQ(m.find(ids[0]), IdMap::kNone);
    m.reset(1000000, 10000);
    EXPECT_EQ(m.pages(), 0u);
    churn(m, static_cast<std::uint32_t>(ids.size()), 20000, &ids);
}

// GidTable against std::map through adds, erasures (slots reused), a keep_only
// and the walk over what it holds, with a dense and a hashed map.
void table_churn(std::size_t gids, std::size_t expected) {
    GidTable<int> t;
    t.reset(gids, expected);
    std::map<std::uint32_t, int> ref;
    std::mt19937 rng(11);
    for (int op = 0; op < 20000; ++op) {
        const std::uint32_t id = static_cast<std::uint32_t>(rng() % 2000) * static_cast<std::uint32_t>(gids / 2000);
        if (rng() % 3 == 0) {
            t.erase(id);
            ref.erase(id);
        } else {
            std::unique_ptr<int>& p = t.at(id);
            if (!p) p = std::make_unique<int>(op);
            ref.emplace(id, *p);
        }
        const int* found = t.find(id);
        ASSERT_EQ(found != nullptr, ref.count(id) == 1) << "id " << id << " op " << op;
        if (found) {
            ASSERT_EQ(*found, ref.at(id));
        }
    }
    t.keep_only(gids, [](std::uint32_t id) { return id % 3 == 0; });
    for (auto it = ref.begin(); it != ref.end();) it = it->first % 3 == 0 ? std::next(it) : ref.erase(it);
    std::map<std::uint32_t, int> walked;
    t.each([&](std::uint32_t id, const int& v) { walked.emplace(id, v); });
    EXPECT_EQ(walked, ref);
    for (std::uint32_t id = 0; id < gids; id += static_cast<std::uint32_t>(gids / 2000)) {
        EXPECT_EQ(t.find(id) != nullptr, ref.count(id) == 1) << id;
    }
}

TEST(GidTable, AgreesWithAMapDense) { table_churn(2000, 2000); }

TEST(GidTable, AgreesWithAMapHashed) { table_churn(2000u * 100000u, 16); }

}  // namespace
