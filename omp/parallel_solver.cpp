// Parallel loops of the contact solver (see parallel_solver.hpp).
#include "parallel_solver.hpp"

#include <algorithm>

#include "register.hpp"

namespace parode::omp {
namespace {
// Below these sizes a parallel region costs more than it saves; results are
// the same either way.
[[maybe_unused]] long min_bodies() { return min_parallel(4096); }
[[maybe_unused]] long min_blocks() { return min_parallel(2048); }

// f(i) for i in [0, n), in contiguous ranges per thread when n >= min_items.
template <class F>
void parallel_for(long n, [[maybe_unused]] long min_items, F&& f) {
#pragma omp parallel for schedule(static) if (n >= min_items)
    for (long i = 0; i < n; ++i) f(static_cast<std::size_t>(i));
}
}  // namespace

void ParallelContactSolver::cell_keys() {
    parallel_for(static_cast<long>(keys().size()), min_blocks(), [this](std::size_t k) { cell_key(k); });
}

// Sorts halves concurrently and merges them: the keys are unique, so the
// result equals the serial sort.
void ParallelContactSolver::sort_keys() {
    auto& k = keys();
    const auto mid = k.begin() + static_cast<long>(k.size() / 2);
    if (static_cast<long>(k.size()) < min_blocks()) {
        ContactSolver::sort_keys();
        return;
    }
#pragma omp parallel sections
    {
#pragma omp section
        std::sort(k.begin(), mid);
#pragma omp section
        std::sort(mid, k.end());
    }
    std::inplace_merge(k.begin(), mid, k.end());
}

void ParallelContactSolver::prepare_bodies() {
    parallel_for(static_cast<long>(world_body_count()), min_bodies(), [this](std::size_t i) { prepare_body(i); });
}

void ParallelContactSolver::build_blocks() {
    const long n = static_cast<long>(blocks());
#pragma omp parallel for schedule(dynamic, 256) if (n >= min_blocks())
    for (long s = 0; s < n; ++s) build_block(static_cast<std::size_t>(s));
}

// `passes` sweeps over the colours; the cells of a colour in contiguous ranges
// per thread (cells are sorted in space), a barrier after each colour.
template <class F>
void ParallelContactSolver::sweep_cells(int passes, F&& per_cell) {
    const int nc = colours();
    [[maybe_unused]] const bool big = static_cast<long>(blocks()) >= min_blocks();
    const bool exchange = exchanging();
#pragma omp parallel if (big)
    for (int it = 0; it < passes; ++it) {
        for (int c = 0; c < nc; ++c) {
            const long b = static_cast<long>(colour_begin(c)), e = static_cast<long>(colour_end(c));
#pragma omp for schedule(static)
            for (long t = b; t < e; ++t) per_cell(static_cast<std::size_t>(t));
            if (exchange) {  // one thread talks to the other processes (MPI_THREAD_FUNNELED)
#pragma omp master
                exchange_after(c);
#pragma omp barrier
            }
        }
    }
}

void ParallelContactSolver::iterate() {
    sweep_cells(iterations(), [this](std::size_t t) { relax_cell(t); });
}

void ParallelContactSolver::warm_start() {
    sweep_cells(1, [this](std::size_t t) { warm_cell(t); });
}

void ParallelContactSolver::remember() {
    parallel_for(static_cast<long>(blocks()), min_blocks(), [this](std::size_t s) { remember_block(s); });
}

void ParallelContactSolver::integrate() {
    parallel_for(static_cast<long>(world_body_count()), min_bodies(), [this](std::size_t i) { integrate_body(i); });
}


}  // namespace parode::omp
