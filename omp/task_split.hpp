// How the OpenMP stages cut a loop into tasks: about one task per `grain`
// items, but never more than 16 tasks per thread of the team. libgomp runs a
// whole taskloop undeferred (serially, in the encountering thread) when it
// would queue more than 64 tasks per thread, so loops over millions of items
// must bound their task count instead of their task size.
// Trade-off: at most 16 tasks per thread still leaves dynamic load balancing
// plenty of pieces, and costs one division per task.
#pragma once
#include <algorithm>
#include <cstddef>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace parode::omp {

// Exclusive prefix over an outer index (blocks, slabs) and an inner one (lanes,
// tasks) of counts[inner * n_outer + outer]: replaces each count with where its
// run starts; outer_start[o] is where outer entry o starts (size n_outer + 1).
inline void outer_inner_offsets(std::size_t n_inner, std::size_t n_outer, std::vector<std::size_t>& counts,
                                std::vector<std::size_t>& outer_start) {
    outer_start.assign(n_outer + 1, 0);
    std::size_t acc = 0;
    for (std::size_t o = 0; o < n_outer; ++o) {
        outer_start[o] = acc;
        for (std::size_t i = 0; i < n_inner; ++i) {
            const std::size_t c = counts[i * n_outer + o];
            counts[i * n_outer + o] = acc;
            acc += c;
        }
    }
    outer_start[n_outer] = acc;
}

inline std::size_t task_count(std::size_t n, std::size_t grain) {
#ifdef _OPENMP
    const std::size_t team = static_cast<std::size_t>(omp_get_num_threads());
#else
    const std::size_t team = 1;
#endif
    const std::size_t wanted = (n + grain - 1) / grain;
    return std::max<std::size_t>(1, std::min(wanted, 16 * team));
}

// Items [begin, end) of task t of `tasks` over n items.
inline std::size_t task_begin(std::size_t n, std::size_t tasks, std::size_t t) {
    return n * t / tasks;
}

}  // namespace parode::omp
