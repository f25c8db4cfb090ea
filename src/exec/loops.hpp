// Loops of the serial core that omp/ may spread over threads. A loop is cut
// into chunks by its caller; the runner calls every chunk once, on one thread
// (the "loops" runner, and every build without OpenMP) or on several
// ("loops/omp"), and whether it uses threads depends on the loop's size only.
// Each Execution (exec/execution.hpp) holds its runner: callers reach it
// through the execution they were given, never through a process global.
// Callers keep results independent of the threads: a chunk writes only its own
// items and its own partial results, which the caller combines in chunk order.
// Trade-off: one indirect call per chunk (chunks are thousands of items), in
// exchange for one place that decides when a loop is worth threads.
#pragma once
#include <cstddef>
#include <functional>
#include <vector>

namespace parode {

class LoopRunner {
public:
    virtual ~LoopRunner() = default;
    // Threads a loop over `items` items runs on (1: serial).
    virtual int threads(std::size_t items) const;
    // f(c) for every chunk c in [0, chunks) of a loop over `items` items.
    virtual void run(std::size_t chunks, std::size_t items, const std::function<void(std::size_t)>& f) const;
};

// First item of chunk c when n items are cut into `chunks` chunks.
inline std::size_t chunk_begin(std::size_t n, std::size_t chunks, std::size_t c) { return n * c / chunks; }

// Chunks for a loop over n items: about one per `grain` items, at most 16 per
// thread and at least one.
std::size_t chunk_count(const LoopRunner& loops, std::size_t n, std::size_t grain);

// Exclusive prefix over an outer index (blocks, slabs, colours) and an inner
// one (chunks, lanes, tasks) of counts[inner * n_outer + outer]: replaces each
// count with where its run starts; outer_start[o] is where outer entry o
// starts (size n_outer + 1). The order in which chunks' results are combined.
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

// f(begin, end) over consecutive ranges covering [0, n).
template <class F>
void for_ranges(const LoopRunner& loops, std::size_t n, std::size_t grain, F&& f) {
    const std::size_t chunks = chunk_count(loops, n, grain);
    loops.run(chunks, n, [&](std::size_t c) { f(chunk_begin(n, chunks, c), chunk_begin(n, chunks, c + 1)); });
}

}  // namespace parode
