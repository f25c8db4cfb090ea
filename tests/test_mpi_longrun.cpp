// The determinism target in full: tennis and magnetic-tennis (2,000 catoms,
// 500 steps, rebalancing) on 1, 2 and 3 processes x 1, 2 and 3 threads give
// the state hash of the run without MPI. Trade-off: nine oversubscribed runs
// per scene take minutes on a 2-core machine, so this is `longrun`; the
// default suite runs 1, 2 and 3 processes (test_mpi.cpp).
#include "mpi_runs.hpp"

namespace {

using namespace mpi_runs;

class RanksByThreads : public Ranks {};

TEST_P(RanksByThreads, SameStateHashAsOneProcess) {
    std::vector<Case> cases;
    for (int r = 1; r <= 3; ++r) {
        for (int t = 1; t <= 3; ++t) cases.push_back({GetParam(), r, t});
    }
    same_hash(cases);
}

INSTANTIATE_TEST_SUITE_P(Classic, RanksByThreads, ::testing::Values("tennis", "magnetic-tennis"));

}  // namespace
