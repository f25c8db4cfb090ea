// Cells of a hash grid over points: a coordinate's cell index (floor, kept
// in range) and a key for a cell's three indices. Shared by the catom
// programs' arrivals and listing (src/programs/program_neighbours.cpp) and
// the neighbour list's patch (omp/grid/neighbour_patch.cpp).
// Trade-off: 21 bits of each index in one 64-bit key, so cells 2^21 apart
// share a key; that only adds candidates, which callers test exactly.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>

namespace parode {

// The cell index of coordinate v (cells of edge 1 from 0): floor, kept
// within +-2^40 (a NaN gives 0) so that the conversion is always defined.
inline std::int64_t cell_index(double v) {
    constexpr double kMost = 1099511627776.0;  // 2^40
    return static_cast<std::int64_t>(std::floor(std::clamp(v == v ? v : 0.0, -kMost, kMost)));
}

// The key of cell (x, y, z): 21 bits of each index.
inline std::int64_t cell_hash_key(std::int64_t x, std::int64_t y, std::int64_t z) {
    constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
    const auto bits = [](std::int64_t v) { return static_cast<std::uint64_t>(v) & kMask; };
    return static_cast<std::int64_t>((bits(x) << 42) | (bits(y) << 21) | bits(z));
}

}  // namespace parode
