// OpenMP loop runner (see loop_runner.hpp).
#include "omp/runtime/loop_runner.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace parode::omp {

int OmpLoopRunner::threads(std::size_t items) const { return exec_.threads_for(items, kLoopCrossover); }

void OmpLoopRunner::run(std::size_t chunks, std::size_t items, const std::function<void(std::size_t)>& f) const {
    const int t = threads(items);
    if (t <= 1 || chunks <= 1) {
        for (std::size_t c = 0; c < chunks; ++c) f(c);
        return;
    }
    const long n = static_cast<long>(chunks);
#pragma omp parallel for schedule(dynamic, 1) num_threads(t)
    for (long c = 0; c < n; ++c) f(static_cast<std::size_t>(c));
}

int default_threads() {
#ifdef _OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}

std::unique_ptr<Execution> omp_execution(ExecutionConfig config) {
    config.loops = "loops/omp";
    return std::make_unique<Execution>(std::move(config),
                                       [](const Execution& e) { return std::make_unique<OmpLoopRunner>(e); });
}

}  // namespace parode::omp
