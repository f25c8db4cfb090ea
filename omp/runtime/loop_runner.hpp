// The OpenMP loop runner "loops/omp" (exec/loops.hpp): the chunks of a loop
// shared among its execution's threads (dynamic, one chunk at a time) when
// the loop is above its crossover and the team is not sharing its cores
// (exec/team.hpp).
// Trade-off: one parallel region per loop (a few microseconds) keeps the core's
// loops free of OpenMP; the loops that matter are large.
#pragma once
#include "exec/execution.hpp"

namespace parode::omp {

class OmpLoopRunner final : public LoopRunner {
public:
    explicit OmpLoopRunner(const Execution& exec) : exec_(exec) {}
    int threads(std::size_t items) const override;
    void run(std::size_t chunks, std::size_t items, const std::function<void(std::size_t)>& f) const override;

private:
    const Execution& exec_;
};

// The threads OpenMP would use by default (OMP_NUM_THREADS, else every core;
// 1 in a build without OpenMP): for callers that build an execution without
// a count of their own.
int default_threads();
// An execution of `config` on this runner: what a stage that runs without a
// pipeline (a standalone CollideEngine) uses.
std::unique_ptr<Execution> omp_execution(ExecutionConfig config);

// Items below which a loop of the core runs on one thread (measured:
// docs/performance/threads-and-small-scenes.md).
constexpr std::size_t kLoopCrossover = 2048;

}  // namespace parode::omp
