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

#include "util/parallel.hpp"  // outer_inner_offsets, the prefix the taskloops combine by

#ifdef _OPENMP
#include <omp.h>
#endif

namespace parode::omp {

// This thread's number in the current team (0 outside OpenMP).
inline int thread_index() {
#ifdef _OPENMP
    return omp_get_thread_num();
#else
    return 0;
#endif
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
