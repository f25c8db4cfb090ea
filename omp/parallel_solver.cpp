// Threaded sweeps of the contact solver (see parallel_solver.hpp).
#include "parallel_solver.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>

#include "team.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace parode::omp {
namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

int thread_index() {
#ifdef _OPENMP
    return omp_get_thread_num();
#else
    return 0;
#endif
}

// A thread waited at a barrier longer than it worked on the colour before it,
// and long enough to be a descheduled thread rather than a slow wake-up or an
// uneven split (1 ms; a time slice is several): threads cost more than they
// give.
bool descheduled(double work, double wait) { return wait > 1e-3 && wait > work; }

}  // namespace

void ParallelContactSolver::step(World& world, const ContactBuffer& contacts) {
    Team::instance().begin_step();
    ContactSolver::step(world, contacts);
    Team::instance().end_step();
}

// Per colour, one cell range per thread holding about equal numbers of contacts.
void ParallelContactSolver::split(int team) {
    const SweepLayout& L = layout();
    const std::size_t t = static_cast<std::size_t>(team);
    ranges_.assign(static_cast<std::size_t>(kColours) * (t + 1), 0);
    for (int c = 0; c < kColours; ++c) {
        const std::size_t b = L.colour_begin(c), e = L.colour_end(c);
        const std::size_t p0 = L.cell_begin(b), p1 = L.cell_begin(e);
        std::size_t* r = ranges_.data() + static_cast<std::size_t>(c) * (t + 1);
        r[0] = b;
        r[t] = e;
        for (std::size_t j = 1; j < t; ++j) {
            const std::size_t target = p0 + (p1 - p0) * j / t;
            std::size_t lo = r[j - 1], hi = e;  // first cell starting at or after target
            while (lo < hi) {
                const std::size_t mid = (lo + hi) / 2;
                if (L.cell_begin(mid) < target) lo = mid + 1;
                else hi = mid;
            }
            r[j] = lo;
        }
    }
}

void ParallelContactSolver::sweep(int passes, bool warm) {
    Team& team = Team::instance();
    // Only the iterations try threads again on shared cores; the warm start
    // (one pass, little work) would mostly wait.
    const int t = warm ? team.threads(contact_count(), kSweepCrossover) : team.sweep_threads(contact_count(), kSweepCrossover);
    if (t <= 1 || passes <= 0) {
        ContactSolver::sweep(passes, warm);
        return;
    }
    split(t);
    team.verdict(sweep_threaded(passes, warm, t));
}

// The threads relax their ranges colour by colour, a barrier after each
// colour. Steps (colours of all passes) are numbered; a thread that waited too
// long at the barrier after step k sets `alone_at` to k + 2 (the least such
// value wins). After the barrier of step k - 1 every thread sees every value
// written before it, and values written after it are at least k + 1, so all
// threads agree whether step k runs alone: from then on thread 0 runs the
// remaining steps by itself and the others leave. Returns whether it did.
bool ParallelContactSolver::sweep_threaded(int passes, bool warm, int team) {
    const std::size_t stride = static_cast<std::size_t>(team) + 1;
    const long steps = static_cast<long>(passes) * kColours;
    std::atomic<long> alone_at{steps};
#pragma omp parallel num_threads(team) shared(alone_at)
    {
        const std::size_t me = static_cast<std::size_t>(thread_index());
        for (long k = 0; k < steps; ++k) {
            const int c = static_cast<int>(k % kColours);
            if (alone_at.load(std::memory_order_acquire) <= k) {
                if (me == 0) finish_alone(k, steps, warm);
                break;
            }
            const std::size_t* r = ranges_.data() + static_cast<std::size_t>(c) * stride;
            const double t0 = now();
            if (warm) warm_cells(r[me], r[me + 1]);
            else relax_cells(r[me], r[me + 1]);
            const double t1 = now();
#pragma omp barrier
            if (exchanging()) {  // one thread talks to the other processes (MPI_THREAD_FUNNELED)
#pragma omp master
                exchange_after(c);
#pragma omp barrier
            }
            if (descheduled(t1 - t0, now() - t1)) {
                long want = k + 2, have = alone_at.load(std::memory_order_relaxed);
                while (want < have && !alone_at.compare_exchange_weak(have, want, std::memory_order_release)) {
                }
            }
        }
    }
    return alone_at.load() < steps;
}

// Steps [from, steps) on this thread: the colours of the pass under way, then
// whole passes.
void ParallelContactSolver::finish_alone(long from, long steps, bool warm) {
    for (long k = from; k < steps; ++k) {
        const int c = static_cast<int>(k % kColours);
        if (warm) warm_cells(layout().colour_begin(c), layout().colour_end(c));
        else relax_cells(layout().colour_begin(c), layout().colour_end(c));
        exchange_after(c);
    }
}

}  // namespace parode::omp
