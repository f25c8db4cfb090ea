// The cells of a scene's initial state (domain/cells.hpp: edge 4 r_max; the
// ghost halo of a distributed run holds the bodies within its reach of a
// rank's cells, distribution.hpp: halo_reach) and the ghosts a partition of
// them into ranks would make, counted without generating a body: the catom
// prism is a lattice, so the catoms of a cell are products of per-axis
// counts; the [[bodies]] are few and counted one by one. `parode info` uses it
// at up to 10^8 catoms (12.6 million cells, a fraction of a second).
// Trade-off: lattice positions without the jitter (a percent of a radius,
// never near a cell boundary in the prism scenes), and ghosts from a
// recursive bisection of the cells' box into blocks of equal bodies (ideal
// planar cuts) rather than METIS's cut of the cell graph: a lower bound of
// the run report's `ghost_fraction`. The halo of the catoms is counted by
// their lattice coordinates (the same per-axis reach test as the run's); that
// of the [[bodies]], few, by whole neighbouring cells.
#pragma once
#include <array>
#include <cstdint>
#include <map>
#include <vector>

#include "scene/scene.hpp"

namespace parode {

struct CellStats {
    double edge = 0;               // 4 r_max
    double r_max = 0;              // largest bounding radius of any body
    double halo = 0;               // the ghost halo's reach (halo_reach)
    std::uint64_t occupied = 0;    // cells holding a body at the start
    double mean_bodies = 0;        // bodies per occupied cell
    std::uint64_t max_bodies = 0;  // in the fullest cell
};

struct GhostEstimate {
    int ranks = 1;
    double bodies_max = 0;   // owned bodies on the fullest rank
    double ghosts_mean = 0;  // ghost copies per rank
    double ghosts_max = 0;
    double fraction = 0;     // ghost copies / bodies (the run report's ghost_fraction)
};

class CellCensus {
public:
    using Cell = std::array<std::int64_t, 3>;
    struct Box {
        Cell lo{}, hi{};  // inclusive
        std::int64_t cells() const { return (hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1); }
    };

    explicit CellCensus(const Scene& scene);
    explicit CellCensus(Scene&&) = delete;  // keeps a reference to the scene
    CellStats stats() const;
    // Owned and ghost bodies per rank when the cells are cut into `ranks` blocks.
    GhostEstimate ghosts(int ranks) const;
    // The box of every occupied cell.
    const Box& box() const { return box_; }
    // Bodies in one cell, and in every cell of a box.
    std::uint64_t count(const Cell& c) const;
    std::uint64_t count(const Box& b) const;

private:
    // The prism's lattice along one axis: cell lo + c holds the lattice
    // indices [first[c], first[c + 1]).
    struct Axis {
        std::int64_t lo = 0;
        std::vector<std::int64_t> first;
        // Lattice indices [i0, i1) of the cells [c0, c1] (empty when outside).
        void indices(std::int64_t c0, std::int64_t c1, std::int64_t& i0, std::int64_t& i1) const;
    };
    Axis lattice_axis(int axis) const;
    std::uint64_t lattice_count(const Box& b) const;
    // Catoms with lattice indices in [i0, i1) x [j0, j1) x [k0, k1).
    std::uint64_t lattice_count(const std::array<std::int64_t, 6>& r) const;
    // Lattice indices of the catoms within `reach` of cells [c0, c1] along an axis.
    void reach_indices(int axis, std::int64_t c0, std::int64_t c1, double reach, std::int64_t& i0, std::int64_t& i1) const;
    double lattice_coord(int axis, std::int64_t i) const;
    std::int64_t cell_of(double x) const;
    void split(const Box& b, int ranks, std::vector<Box>& leaves) const;

    const Scene& scene_;
    double edge_;
    double reach_;  // the halo's (halo_reach)
    std::array<Axis, 3> axes_;
    std::int64_t full_layers_ = 0, top_rows_ = 0, top_rest_ = 0;  // the prism's partial top layer
    std::map<Cell, std::uint64_t> listed_;  // cells of the [[bodies]]
    Box box_;
};

}  // namespace parode
