// Loops of the serial core that omp/ may spread over threads. A loop is cut
// into chunks by its caller; the runner calls every chunk once, on one thread
// (the default, and every build without OpenMP) or on several (the runner omp/
// installs), and whether it uses threads depends on the loop's size only.
// Callers keep results independent of the threads: a chunk writes only its own
// items and its own partial results, which the caller combines in chunk order.
// Trade-off: one indirect call per chunk (chunks are thousands of items), in
// exchange for one place that decides when a loop is worth threads.
#pragma once
#include <cstddef>
#include <functional>

namespace parode {

class LoopRunner {
public:
    virtual ~LoopRunner() = default;
    // Threads a loop over `items` items runs on (1: serial).
    virtual int threads(std::size_t items) const;
    // f(c) for every chunk c in [0, chunks) of a loop over `items` items.
    virtual void run(std::size_t chunks, std::size_t items, const std::function<void(std::size_t)>& f) const;
};

// The runner in use (serial unless omp/ installed one); null restores the serial one.
const LoopRunner& loops();
void set_loop_runner(const LoopRunner* runner);

// First item of chunk c when n items are cut into `chunks` chunks.
inline std::size_t chunk_begin(std::size_t n, std::size_t chunks, std::size_t c) { return n * c / chunks; }

// Chunks for a loop over n items: about one per `grain` items, at most 16 per
// thread and at least one.
std::size_t chunk_count(std::size_t n, std::size_t grain);

// f(begin, end) over consecutive ranges covering [0, n).
template <class F>
void for_ranges(std::size_t n, std::size_t grain, F&& f) {
    const std::size_t chunks = chunk_count(n, grain);
    loops().run(chunks, n, [&](std::size_t c) { f(chunk_begin(n, chunks, c), chunk_begin(n, chunks, c + 1)); });
}

}  // namespace parode
