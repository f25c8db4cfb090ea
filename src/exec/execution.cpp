// The execution context (see execution.hpp).
#include "exec/execution.hpp"

#include <algorithm>
#include <stdexcept>

namespace parode {

namespace {

ExecutionConfig checked(ExecutionConfig c) {
    if (c.threads < 1) {
        throw std::invalid_argument("threads: expected an integer of at least 1, got " + std::to_string(c.threads));
    }
    return c;
}

}  // namespace

Execution::Execution(ExecutionConfig config, const LoopRunnerFactory& runner)
    : config_(checked(std::move(config))), team_(config_.threads, config_.min_parallel, config_.adaptive) {
    if (runner) loops_ = runner(*this);
    if (!loops_) loops_ = std::make_unique<LoopRunner>();
    loops_name_ = config_.loops.empty() ? "loops" : config_.loops;
}

}  // namespace parode
