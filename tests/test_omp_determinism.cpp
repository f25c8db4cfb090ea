// Thread-count independence of the OpenMP stages: after 200 steps of tennis and
// magnetic-tennis (1,000 catoms), the grid backend on 1, 2, 3 and 4 threads
// (with the parallel magnet pass) gives the state hash of ODE's hash space.
// Trade-off: whole-pipeline hashes catch any difference anywhere in the step;
// the contact-level comparisons live in tests/omp/.
#include <gtest/gtest.h>

#include <cstring>

#include "util/hash.hpp"
#include "register.hpp"
#include "test_support.hpp"

using namespace parode;

namespace {

class ThreadCounts : public ::testing::TestWithParam<const char*> {};

TEST_P(ThreadCounts, GridOnOneToFourThreadsMatchesOdeHashSpace) {
    const Scene sc = test::repo_scene(std::string("jobs/scenes/") + GetParam() + ".toml", {"catoms.count=1000"});
    const std::string reference = hex64(test::hash_after(sc, 200, "ode-hash", 1));
    for (int threads = 1; threads <= 4; ++threads) {
        EXPECT_EQ(hex64(test::hash_after(sc, 200, "grid", threads)), reference) << threads << " threads";
    }
}

INSTANTIATE_TEST_SUITE_P(Classic, ThreadCounts, ::testing::Values("tennis", "magnetic-tennis"));

TEST(ThreadCounts, ParallelMagnetGatherEqualsSerialGather) {
    Scene sc = test::repo_scene("jobs/scenes/magnetic-tennis.toml", {"catoms.count=343"});
    auto p = test::run(sc, 20, "ode-hash", 1);
    MagnetField field(sc);
    field.prepare(p->world());
    std::vector<BodyWrench> serial(field.members().size());
    for (std::size_t k = 0; k < serial.size(); ++k) serial[k] = field.gather(k);
    for (int threads = 1; threads <= 4; ++threads) {
        parode::omp::set_threads(threads);
        parode::omp::set_min_parallel(0);
        std::vector<BodyWrench> par;
        gather_magnets(field, par);
        ASSERT_EQ(par.size(), serial.size());
        for (std::size_t k = 0; k < serial.size(); ++k) {
            ASSERT_EQ(0, std::memcmp(&par[k], &serial[k], sizeof(BodyWrench))) << "body " << k << ", " << threads << " threads";
        }
    }
}

}  // namespace
