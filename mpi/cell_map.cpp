// Cell ownership (see cell_map.hpp).
#include "cell_map.hpp"

#include <algorithm>
#include <cstdlib>

#include "domain/cells.hpp"
#include "partition.hpp"
#include "util/split_mix.hpp"

namespace parode::mpi {

void CellMap::assign(std::vector<std::uint64_t> keys, std::vector<int> owners, int ranks, int edge) {
    keys_ = std::move(keys);
    owners_ = std::move(owners);
    ranks_ = ranks;
    edge_ = std::max(edge, 1);
    by_tree_ = false;
    tree_ = CutTree();
    rank_of_.clear();
    forget_cells();
}

void CellMap::assign(CutTree tree, std::vector<int> rank_of) {
    keys_.clear();
    owners_.clear();
    ranks_ = static_cast<int>(rank_of.size());
    edge_ = 1;
    by_tree_ = true;
    tree_ = std::move(tree);
    rank_of_ = std::move(rank_of);
    forget_cells();
}

int CellMap::mapped_owner(std::uint64_t key) const {
    const auto it = std::lower_bound(keys_.begin(), keys_.end(), key);
    if (it == keys_.end() || *it != key) return -1;
    return owners_[static_cast<std::size_t>(it - keys_.begin())];
}

// Shell by shell, the mapped cells at Chebyshev distance d; the smallest key
// of the first shell that has any decides.
int CellMap::nearest_owner(std::uint64_t key) const {
    for (int d = 1; d <= kReach; ++d) {
        std::uint64_t best = ~0ULL;
        int who = -1;
        for (int x = -d; x <= d; ++x) {
            for (int y = -d; y <= d; ++y) {
                for (int z = -d; z <= d; ++z) {
                    if (std::max({std::abs(x), std::abs(y), std::abs(z)}) != d) continue;
                    const std::uint64_t k = CellSpace::neighbour(key, x, y, z);
                    const int o = mapped_owner(k);
                    if (o >= 0 && k < best) {
                        best = k;
                        who = o;
                    }
                }
            }
        }
        if (who >= 0) return who;
    }
    return static_cast<int>(SplitMix64::mix(key) % static_cast<std::uint64_t>(ranks_));
}

// What the caches hold belongs to the partition just replaced.
void CellMap::forget_cells() {
    owner_cache_.clear();
    cells_.clear();
    around_.clear();
    around_.shrink_to_fit();
    alone_.clear();
    holder_lists_.clear();
}

int CellMap::owner(std::uint64_t cell) const {
    if (by_tree_) return rank_of_[static_cast<std::size_t>(tree_.part(cell))];
    const std::uint64_t key = block_of(cell, edge_);
    const int o = mapped_owner(key);
    if (o >= 0) return o;
    const std::uint32_t known = owner_cache_.find(key);
    if (known != CellCache::kNone) return static_cast<int>(known);
    const int n = nearest_owner(key);
    owner_cache_.add(key, static_cast<std::uint32_t>(n));
    return n;
}

const std::vector<int>& CellMap::interned(std::vector<int> h) const {
    std::sort(h.begin(), h.end());
    h.erase(std::unique(h.begin(), h.end()), h.end());
    return *holder_lists_.insert(std::move(h)).first;
}

const std::vector<int>& CellMap::alone(int owner) const {
    const auto o = static_cast<std::size_t>(owner);
    if (alone_.size() <= o) alone_.resize(o + 1, nullptr);
    if (!alone_[o]) alone_[o] = &interned({owner});
    return *alone_[o];
}

const std::vector<int>& CellMap::holders(std::uint64_t key, std::uint8_t sides) const {
    std::uint32_t v = cells_.find(key);
    if (v != CellCache::kNone && (v & kAround) == 0) return alone(static_cast<int>(v));  // most cells: no list to build
    if (v == CellCache::kNone) {
        std::array<int, 27> a{};
        for (int j = 0; j < 27; ++j) a[static_cast<std::size_t>(j)] = owner(CellSpace::neighbour(key, j / 9 - 1, j / 3 % 3 - 1, j % 3 - 1));
        if (std::all_of(a.begin(), a.end(), [&a](int o) { return o == a[0]; })) {
            cells_.add(key, static_cast<std::uint32_t>(a[0]));
            return alone(a[0]);
        }
        v = kAround | static_cast<std::uint32_t>(around_.size());
        around_.push_back(a);
        cells_.add(key, v);
    }
    const std::array<int, 27>& around = around_[v & ~kAround];
    // Neighbour d of the cell is reached when every axis with d_a = -1 has
    // its lower side in `sides` and every axis with d_a = +1 its upper one.
    const auto reached = [sides](int d, int axis) { return d == 0 || ((sides >> (2 * axis + (d > 0 ? 1 : 0))) & 1); };
    std::vector<int> h;
    for (int j = 0; j < 27; ++j) {
        if (reached(j / 9 - 1, 0) && reached(j / 3 % 3 - 1, 1) && reached(j % 3 - 1, 2)) h.push_back(around[static_cast<std::size_t>(j)]);
    }
    return interned(std::move(h));
}

}  // namespace parode::mpi
