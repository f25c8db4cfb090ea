// Which process owns each cell of the global cell grid (domain/cells.hpp).
// The map holds the occupied blocks of the last partition (cubes of `edge`
// cells a side, partition.hpp: block_edge) with their owners, the same on
// every process; a cell belongs to the owner of its block. A block that was
// empty then (a ball rolling out across the floor enters one) belongs to the
// owner of the nearest mapped block (Chebyshev distance, the smallest key
// among equally near ones); past kReach blocks, to the rank given by a hash
// of its key. So the owner of any cell is a pure function of the map, and
// every process agrees on it without a message.
// holders(key, sides): the owners of the cell and of those of its 26
// neighbours a body there reaches (CellSpace::key with a reach: the faces it lies
// within reach of; all 27 cells with kAllSides); the body is owned by the
// owner of its cell and copied (a ghost) to every other holder, which covers
// all its contact, magnet and message partners. With the reach of contacts
// alone (2 r_max, half a cell) a body reaches only the neighbours on the
// nearer side of each axis: half the copies of whole neighbouring cells.
// A partition the processes made together (cut_tree.hpp) is kept as its tree
// of cuts instead (2 parts - 1 nodes) with the rank of each part: the owner
// of any cell is then its part's rank, and no list of cells is kept at all.
// Trade-off: a gathered partition's map is replicated (12 bytes per occupied
// block on every process, up to 64 times fewer than cells), which keeps
// lookups local and deterministic; beyond the size the root partitions
// (partition.hpp: kGatherUnits) the tree replaces it, whose lookups descend
// log2(ranks) cuts. The 27 owners around a cell are cached for the cells
// this process meets (its own and its neighbours', a local size) where more
// than one rank owns them, one owner for the others (cell_cache.hpp: 16 to
// 32 bytes a cell), and each distinct list of holders is kept once.
#pragma once
#include <array>
#include <cstdint>
#include <set>
#include <vector>

#include "cell_cache.hpp"
#include "cut_tree.hpp"

namespace parode::mpi {

class CellMap {
public:
    static constexpr int kReach = 8;

    // `keys` (blocks of `edge` cells a side, partition.hpp: block_of) sorted
    // ascending, `owners[i]` the rank of keys[i].
    void assign(std::vector<std::uint64_t> keys, std::vector<int> owners, int ranks, int edge = 1);
    // The partition as a tree of cuts, part p on rank rank_of[p].
    void assign(CutTree tree, std::vector<int> rank_of);
    int edge() const { return edge_; }
    int owner(std::uint64_t cell) const;
    // Sorted distinct ranks owning the cell and the neighbours on its
    // `sides` (CellSpace::key with a reach); the reference stays valid until assign.
    const std::vector<int>& holders(std::uint64_t key, std::uint8_t sides) const;
    std::size_t mapped() const { return keys_.size(); }
    const std::vector<std::uint64_t>& keys() const { return keys_; }
    const std::vector<int>& owners() const { return owners_; }

private:
    int mapped_owner(std::uint64_t key) const;  // -1 when not mapped
    int nearest_owner(std::uint64_t key) const;
    void forget_cells();  // empties every cache of cells met

    std::vector<std::uint64_t> keys_;
    std::vector<int> owners_;
    int ranks_ = 1;
    int edge_ = 1;
    bool by_tree_ = false;
    CutTree tree_;
    std::vector<int> rank_of_;  // per part of tree_
    mutable CellCache owner_cache_;  // unmapped blocks met: their nearest owner
    const std::vector<int>& interned(std::vector<int> h) const;
    const std::vector<int>& alone(int owner) const;  // the interned list {owner}
    // Per cell met: its one owner when one rank owns all 27 cells around it
    // (an interior cell, most of them), else kAround | the index of its 27
    // owners, in (x, y, z) offset order, in around_.
    static constexpr std::uint32_t kAround = 0x80000000u;
    mutable CellCache cells_;
    mutable std::vector<std::array<int, 27>> around_;
    mutable std::vector<const std::vector<int>*> alone_;  // per rank, once met
    mutable std::set<std::vector<int>> holder_lists_;
};

}  // namespace parode::mpi
