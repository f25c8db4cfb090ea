// Parallel magnet gather (see magnet_pass.cpp).
#pragma once
#include <vector>

#include "forces/magnets.hpp"

namespace parode::omp {
void gather_magnets_parallel(const MagnetField& field, std::vector<BodyWrench>& out);
}
