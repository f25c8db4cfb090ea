// The global cell grid of a scene: cubes of edge 4 r_max (r_max the largest
// bounding radius of any body) from one origin for every process. The
// contact solver orders its work by these cells (a contact belongs to the
// cell of its lower-id body; 8 colours by the parity of the cell
// coordinates), and the distributed layer partitions them among processes,
// so every key and every order is the same on every process.
// A key packs the three cell coordinates, biased by 2^19 and 20 bits each
// (+-524,288 cells per axis, +-1,048 km at r_max 0.5 m); the colour is the
// parity of each coordinate. Coordinates past that range wrap, which merges
// far cells into one key: harmless for correctness (a merged cell is relaxed
// as one), and far beyond the position bounds of a scene.
// Trade-off: a body is at most 2 r_max from any body it touches, so its
// contacts span two cells per axis of different parity, and two cells of one
// colour never share a body; the price is cells 8x the volume of a body's
// neighbourhood, so fewer, larger cells to spread among threads and ranks.
#pragma once
#include <cmath>
#include <cstdint>

#include "scene/scene.hpp"

namespace parode {

class CellSpace {
public:
    static constexpr int kBits = 20;
    static constexpr std::uint64_t kMask = (std::uint64_t{1} << kBits) - 1;
    static constexpr std::int64_t kBias = std::int64_t{1} << (kBits - 1);

    explicit CellSpace(const Scene& scene) : edge_(4 * scene.max_bounding_radius() * (1 + 1e-9)) {}
    double edge() const { return edge_; }

    std::uint64_t key(const double x[3]) const {
        std::uint64_t k = 0;
        for (int a = 0; a < 3; ++a) {
            const auto q = static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(x[a] / edge_)) + kBias) & kMask;
            k |= q << (kBits * a);
        }
        return k;
    }
    // The key of x's cell, and in `sides` which neighbours of that cell a body
    // at x may reach within `reach` (a contact, a magnet, a program's
    // message), two bits per axis: bit 2a the lower neighbour along axis a
    // (the body within reach of its cell's lower face), bit 2a + 1 the upper
    // one. Key and fraction come from one floor, and the test is widened by
    // kSideMargin of an edge, so a partner no farther than `reach` is never
    // on a side left out.
    static constexpr double kSideMargin = 1e-6;
    std::uint64_t key(const double x[3], double reach, std::uint8_t& sides) const {
        const double near = reach / edge_ + kSideMargin;
        std::uint64_t k = 0;
        sides = 0;
        for (int a = 0; a < 3; ++a) {
            const double t = x[a] / edge_, cell = std::floor(t), f = t - cell;
            k |= (static_cast<std::uint64_t>(static_cast<std::int64_t>(cell) + kBias) & kMask) << (kBits * a);
            if (f < near) sides = static_cast<std::uint8_t>(sides | (1u << (2 * a)));
            if (f > 1 - near) sides = static_cast<std::uint8_t>(sides | (2u << (2 * a)));
        }
        return k;
    }
    static constexpr std::uint8_t kAllSides = 0x3f;
    static int colour(std::uint64_t key) {
        return static_cast<int>((key & 1) | ((key >> (kBits - 1)) & 2) | ((key >> (2 * kBits - 2)) & 4));
    }
    static std::uint64_t coord(std::uint64_t key, int axis) { return (key >> (kBits * axis)) & kMask; }
    // The key of the cell (dx, dy, dz) cells away, wrapping.
    static std::uint64_t neighbour(std::uint64_t key, int dx, int dy, int dz) {
        const int d[3] = {dx, dy, dz};
        std::uint64_t k = 0;
        for (int a = 0; a < 3; ++a) k |= ((coord(key, a) + static_cast<std::uint64_t>(d[a])) & kMask) << (kBits * a);
        return k;
    }

private:
    double edge_;
};

}  // namespace parode
