// The execution context of one pipeline: how many threads its stages use and
// where that number came from, the crossovers below which a loop stays on one
// thread, the team's sharing verdicts, the loop runner of the core's loops,
// the scratch pool that the collider and the solver lend each other, and
// whether SIMD kernels may run. Built once, from the command line
// (cli/) or by a library caller, and handed to every stage the pipeline
// makes; no stage reads a process global for any of these, so two pipelines
// in one process can run side by side with different thread counts.
// Every OpenMP region a stage opens names its thread count from here
// (`num_threads`); parode never calls omp_set_num_threads.
// Trade-off: stages keep a reference to their execution (it must outlive
// them), instead of a parameter on every call: the interfaces stay as they
// were and a stage cannot be handed two different contexts by mistake.
#pragma once
#include <functional>
#include <memory>
#include <string>

#include "exec/loops.hpp"
#include "exec/team.hpp"
#include "util/scratch_pool.hpp"

namespace parode {

struct ExecutionConfig {
    int threads = 1;                                 // >= 1
    std::string threads_from = "the default (one thread)";  // for the run report
    long min_parallel = -1;  // >= 0: every loop from this many items threaded, whatever its crossover
    bool adaptive = true;    // sharing verdicts (team.hpp); off: threads always tried
    bool simd = true;        // AVX2 kernels where the machine has them (same results either way)
    std::string loops;       // the loop runner (a name of the "loops" registry); empty: the best built
};

class Execution;
using LoopRunnerFactory = std::function<std::unique_ptr<LoopRunner>(const Execution&)>;

class Execution {
public:
    // `runner` makes the loop runner (null: the serial one).
    explicit Execution(ExecutionConfig config = {}, const LoopRunnerFactory& runner = nullptr);
    Execution(const Execution&) = delete;
    Execution& operator=(const Execution&) = delete;

    const ExecutionConfig& config() const { return config_; }
    int threads() const { return config_.threads; }
    const std::string& threads_from() const { return config_.threads_from; }
    bool simd() const { return config_.simd; }
    // The crossover in force for a loop whose measured crossover is `items`.
    long crossover(long items) const { return team_.crossover(items); }
    // Threads for a loop of `items` items with crossover `crossover`.
    int threads_for(std::size_t items, std::size_t crossover) const { return team_.threads(items, crossover); }
    Team& team() { return team_; }
    const Team& team() const { return team_; }
    const LoopRunner& loops() const { return *loops_; }
    const std::string& loops_name() const { return loops_name_; }
    ScratchPool& scratch() { return scratch_; }

private:
    ExecutionConfig config_;
    Team team_;
    std::unique_ptr<LoopRunner> loops_;
    std::string loops_name_;
    ScratchPool scratch_;
};

}  // namespace parode
