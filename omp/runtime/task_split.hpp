// How the OpenMP stages cut a loop into tasks: about one task per `grain`
// items, but never more than 16 tasks per thread of the team. libgomp runs a
// whole taskloop undeferred (serially, in the encountering thread) when it
// would queue more than 64 tasks per thread, so loops over millions of items
// must bound their task count instead of their task size.
// Trade-off: at most 16 tasks per thread still leaves dynamic load balancing
// plenty of pieces, and costs one division per task.
#pragma once
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "exec/execution.hpp"  // outer_inner_offsets, the prefix the taskloops combine by
#include "util/scratch.hpp"

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

// Threads of the current team (1 outside OpenMP).
inline std::size_t team_threads() {
#ifdef _OPENMP
    return static_cast<std::size_t>(omp_get_num_threads());
#else
    return 1;
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

// The indices [0, n) that class_of(i) puts in class 1 into `first` and those
// in class 2 into `second` (any other class: neither), in index order, in
// tasks over the blocks task_begin(n, counts.size(), b) gives; counts[b]
// holds block b's two counts, taken beforehand by the same blocks. Only the
// prefix over blocks is serial.
template <class ClassOf>
void split_in_order(std::size_t n, const std::vector<std::array<std::size_t, 2>>& counts, ClassOf class_of,
                    std::vector<std::uint32_t>& first, std::vector<std::uint32_t>& second) {
    const std::size_t blocks = counts.size();
    std::vector<std::array<std::size_t, 2>> starts(blocks);
    std::array<std::size_t, 2> total = {0, 0};
    for (std::size_t b = 0; b < blocks; ++b) {
        starts[b] = total;
        total[0] += counts[b][0];
        total[1] += counts[b][1];
    }
    scratch_resize(first, total[0]);  // every element is written below
    scratch_resize(second, total[1]);
    const std::array<std::size_t, 2>* start = starts.data();
    std::uint32_t* to_first = first.data();
    std::uint32_t* to_second = second.data();
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(class_of, start, to_first, to_second, n, blocks)
    for (std::size_t b = 0; b < blocks; ++b) {
        std::size_t f = start[b][0], s = start[b][1];
        for (std::size_t i = task_begin(n, blocks, b); i < task_begin(n, blocks, b + 1); ++i) {
            const int c = class_of(i);
            if (c == 1) to_first[f++] = static_cast<std::uint32_t>(i);
            if (c == 2) to_second[s++] = static_cast<std::uint32_t>(i);
        }
    }
}

}  // namespace parode::omp
