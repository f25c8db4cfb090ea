// Partitioning of the occupied cells among processes with METIS
// (METIS_PartGraphKway, multi-constraint). The graph: one vertex per occupied
// cell with one weight per colour (the work in the cell, bodies + contacts,
// in its colour's slot) and one for its bodies: the contact solver waits for
// the slowest process after every colour, so each colour's work is balanced
// apart, not only each process's total; an edge between cells that touch
// (the 26 neighbours), weighted by the bodies of the two cells, which are what
// becomes ghosts if the edge is cut: the edge cut is the boundary traffic.
// No MPI here: the distributed layer gathers the cells to one process, calls
// this, and broadcasts the result.
// Trade-off: serial METIS on one process sees the whole graph (the best
// partitions, deterministic with a fixed seed) but holds every occupied cell
// (about 0.4 KB each with METIS's work arrays); ParMETIS is not in Debian.
#pragma once
#include <cstdint>
#include <vector>

namespace parode::mpi {

struct CellLoad {
    std::uint64_t key;
    std::int64_t work;    // bodies + contacts
    std::int64_t bodies;
};

struct Partition {
    std::vector<std::uint64_t> keys;  // sorted
    std::vector<int> owner;           // per key
    std::int64_t edge_cut = 0;        // sum of cut edge weights
    double imbalance = 1.0;           // max part work / mean part work
    // The sum over colours of the largest part's work in that colour, over
    // the sum of the means: what the solver's per-colour waits cost.
    double colour_imbalance = 1.0;
};

// Sorts `cells` by key and adds up duplicate keys (the same cell listed by
// several processes).
std::vector<CellLoad> merge_cells(std::vector<CellLoad> cells);
// What the partition balances: each colour's work and the bodies (the
// default), or each part's total work alone (one constraint).
enum class Balance { Colours, Total };
// `cells` merged (sorted, unique keys). Deterministic: the same cells give
// the same partition.
Partition partition_cells(const std::vector<CellLoad>& cells, int parts, Balance balance = Balance::Colours);
// Renumbers the parts of `p` (same cells, same cut) so that as much work as
// possible stays on the process that holds it: held[r] are the cells process
// r holds now. METIS numbers its parts afresh each call, so without this a
// repartition moves bodies whose part did not change, only its number.
// Greedy by overlap (largest first; ties by part, then process), which is
// deterministic and near the optimum when parts drift a little.
void keep_owners(Partition& p, const std::vector<std::vector<CellLoad>>& held, int parts);

}  // namespace parode::mpi
