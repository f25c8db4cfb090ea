// Partitioning of the occupied cells among processes with METIS
// (METIS_PartGraphKway, multi-constraint), or by recursive coordinate
// bisection (cut_tree.hpp), whichever balances the colours better. The graph: one vertex per occupied
// cell with one weight per colour (the work in the cell, bodies + contacts,
// in its colour's slot) and one for its bodies: the contact solver waits for
// the slowest process after every colour, so each colour's work is balanced
// apart, not only each process's total; an edge between cells that touch
// (the 26 neighbours), weighted by the bodies of the two cells, which are what
// becomes ghosts if the edge is cut: the edge cut is the boundary traffic.
// No MPI here: the distributed layer gathers the cells to one process, calls
// this, and broadcasts the result; beyond kGatherUnits cells it builds the
// bisection's tree together instead (cut_tree.hpp).
// Trade-off: serial METIS on one process sees the whole graph (the best
// partitions, deterministic with a fixed seed) but holds every occupied cell
// (about 0.4 KB each with METIS's work arrays); ParMETIS is not in Debian.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

namespace parode::mpi {

// The load of one unit of the partition: a cell, or a block of cells (its
// key then packs the block's coordinates as a cell key packs a cell's).
struct CellLoad {
    std::uint64_t key;
    std::int64_t work;    // bodies + contacts
    std::int64_t bodies;
    // The work of the unit's cells of each colour; all zero: a cell, whose
    // work is all of its own colour (CellSpace::colour of its key).
    std::array<std::int64_t, 8> colour{};
};

// The block of edge `edge` cells holding cell `key` (its coordinates divided
// by `edge`), as a key; edge 1: the cell itself.
std::uint64_t block_of(std::uint64_t key, int edge);
// `cells` summed into blocks of edge `edge` (sorted, unique keys), each with
// its colours' work apart.
std::vector<CellLoad> coarsen(const std::vector<CellLoad>& cells, int edge);
// The block edge for `cells` occupied cells on `parts` parts: 1 (cells) up
// to 4 million cells (about 32 million catoms), else the smallest power of 2
// that brings the blocks under 4 million, while every part keeps at least 64
// blocks. The root's METIS graph and every process's map then stay under 4
// million entries whatever the machine; coarser units balance the colours
// less finely (measured at 10^6 catoms on 2 ranks: colour imbalance 1.012 on
// cells, 1.037 on blocks of 2 cells a side, 1.046 of 4).
int block_edge(std::int64_t cells, int parts);

struct Partition {
    std::vector<std::uint64_t> keys;  // sorted
    std::vector<int> owner;           // per key
    std::int64_t edge_cut = 0;        // sum of cut edge weights
    double imbalance = 1.0;           // max part work / mean part work
    // The sum over colours of the largest part's work in that colour, over
    // the sum of the means: what the solver's per-colour waits cost.
    double colour_imbalance = 1.0;
    bool bisection = false;  // made by bisect_parts, not METIS
};

std::array<std::int64_t, 8> colour_work(const CellLoad& c);
// A partition's balance from each part's work and each part's work by
// colour (part * 8 + colour): the largest part's work over the mean, and the
// sum over colours of the largest part's work over the sum of the means.
void balance_of(const std::vector<std::int64_t>& work, const std::vector<std::int64_t>& by_colour, double& imbalance,
                double& colour_imbalance);
// Sorts `cells` by key and adds up duplicate keys (the same cell listed by
// several processes).
std::vector<CellLoad> merge_cells(std::vector<CellLoad> cells);
// What the partition balances: each colour's work and the bodies (the
// default), or each part's total work alone (one constraint).
enum class Balance { Colours, Total };
// Who cuts: the better balanced of METIS's and the bisection's partitions
// (Best: the smaller colour imbalance; within 0.5 %, the smaller edge cut),
// or one of them.
enum class Partitioner { Best, Metis, Bisection };
// `cells` merged (sorted, unique keys). Deterministic: the same cells give
// the same partition.
Partition partition_cells(const std::vector<CellLoad>& cells, int parts, Balance balance = Balance::Colours,
                          Partitioner who = Partitioner::Best);
// Recursive coordinate bisection of `units` (merged) into `parts` of equal
// work, cut between pairs of cell layers (cut_tree.hpp); the owner of each unit.
std::vector<int> bisect_parts(const std::vector<CellLoad>& units, int parts);
// Renumbers the parts of `p` (same cells, same cut) so that as much work as
// possible stays on the process that holds it: held[r] are the cells process
// r holds now. METIS numbers its parts afresh each call, so without this a
// repartition moves bodies whose part did not change, only its number.
// Greedy by overlap (largest first; ties by part, then process), which is
// deterministic and near the optimum when parts drift a little.
void keep_owners(Partition& p, const std::vector<std::vector<CellLoad>>& held, int parts);
// The work a process holds in a part, as keep_owners weighs it.
struct Overlap {
    std::int64_t work;
    int part, process;
};
// keep_owners's choice from the overlaps (pairs listed more than once are
// summed): the process that takes each part.
std::vector<int> ranks_by_overlap(std::vector<Overlap> o, int parts);
// Occupied cells (summed over processes) up to which the default
// partitioner gathers them to the root to compare METIS's partition with the
// bisection's (at about 0.4 KB a cell there, about 2 million catoms of a
// prism); beyond, the processes cut the bisection's tree together
// (cut_tree.hpp) and nothing the size of the scene is held anywhere.
constexpr std::int64_t kGatherUnits = std::int64_t{1} << 18;

}  // namespace parode::mpi
