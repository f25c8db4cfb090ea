// Adds the distributed decomposition "mpi" (MpiDomain: METIS-partitioned
// cells, ghost exchange, the solver's per-colour corrections) to the stage
// registry (run/stages.hpp). A pipeline uses it when RunOptions::domain is
// "mpi", which the command line sets under a launcher with 2+ processes.
// Trade-off: explicit registration, as omp::add_stages.
#pragma once
#include "run/stages.hpp"

namespace parode::mpi {
void add_stages(Stages& stages = Stages::instance());
}  // namespace parode::mpi
