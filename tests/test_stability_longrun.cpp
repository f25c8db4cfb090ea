// The big hard case: the tennis prism with 100,000 catoms (jobs/scenes/hard/
// pile-100k.toml) passes its [checks] (no NaN, bounded penetration, no energy
// gain) over 200 steps of the collapse. Label `longrun`: minutes on 2 cores.
// Trade-off: 200 steps cover the first contacts and the start of the collapse,
// where penetration and energy errors peak, not the settled pile.
#include <gtest/gtest.h>

#include "test_support.hpp"

using namespace parode;

TEST(StabilityLongrun, Pile100kCollapsesCleanly) {
    const Scene sc = test::repo_scene("jobs/scenes/hard/pile-100k.toml");
    auto p = test::run(sc, sc.steps, "grid");  // ODE's hash space needs O(n^2) memory at this size
    const nlohmann::json r = p->checks_result();
    EXPECT_TRUE(r.at("passed").get<bool>()) << r.dump();
    EXPECT_EQ(p->last().nan_count, 0u);
}
