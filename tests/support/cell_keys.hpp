// Cell keys for the partition tests: the cell (x, y, z) cells away from the
// grid's origin cell, as domain/cells.hpp packs it.
#pragma once
#include <cstdint>

#include "domain/cells.hpp"

namespace parode::test {

inline std::uint64_t key_of(int x, int y, int z) {
    const std::uint64_t origin = CellSpace::neighbour(0, 0, 0, 0);
    return CellSpace::neighbour(origin, x, y, z);
}

}  // namespace parode::test
