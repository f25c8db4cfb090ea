// The OpenMP loop runner of util/parallel.hpp: the chunks of a loop shared
// among the team's threads (dynamic, one chunk at a time) when the loop is
// above its crossover and the team is not sharing its cores (team.hpp).
// Trade-off: one parallel region per loop (a few microseconds) keeps the core's
// loops free of OpenMP; the loops that matter are large.
#pragma once
#include "util/parallel.hpp"

namespace parode::omp {

class OmpLoopRunner final : public LoopRunner {
public:
    int threads(std::size_t items) const override;
    void run(std::size_t chunks, std::size_t items, const std::function<void(std::size_t)>& f) const override;
};

// Items below which a loop of the core runs on one thread (measured: README.md).
constexpr std::size_t kLoopCrossover = 2048;

}  // namespace parode::omp
