// Threaded sweeps of the contact solver (see parallel_solver.hpp).
#include "parallel_solver.hpp"

#include <algorithm>
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

// Per thread, padded to its own cache line: seconds working and waiting.
struct alignas(64) Clock {
    double work = 0, wait = 0;
};

// A thread waited at the barriers more than half as long as it worked, and
// long enough to be a descheduled thread rather than a slow wake-up (200 us;
// a time slice is milliseconds): the threads cost more than they give.
bool too_much_waiting(const std::vector<Clock>& clocks) {
    for (const Clock& c : clocks) {
        if (c.wait > 0.5 * c.work && c.wait > 2e-4) return true;
    }
    return false;
}

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
    const int t = team.sweep_threads(contact_count(), kSweepCrossover);
    if (t <= 1 || passes <= 0) {
        ContactSolver::sweep(passes, warm);
        return;
    }
    split(t);
    team.verdict(sweep_threaded(passes, warm, t));
}

// The threads relax their ranges colour by colour; each iteration's clocks
// (barriers of colours 0-6, written between the last two barriers) decide
// after the last barrier, identically on every thread, whether thread 0 goes
// on alone. Returns whether it did.
bool ParallelContactSolver::sweep_threaded(int passes, bool warm, int team) {
    const std::size_t stride = static_cast<std::size_t>(team) + 1;
    std::vector<Clock> seen(static_cast<std::size_t>(team));
    bool went_alone = false;
#pragma omp parallel num_threads(team) shared(seen, went_alone)
    {
        const std::size_t me = static_cast<std::size_t>(thread_index());
        bool alone = false;
        for (int it = 0; it < passes; ++it) {
            if (alone) {
                if (me != 0) break;
                ContactSolver::sweep(1, warm);
                continue;
            }
            Clock mine;
            for (int c = 0; c < kColours; ++c) {
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
                mine.work += t1 - t0;
                mine.wait += now() - t1;
                if (c == kColours - 2) seen[me] = mine;
            }
            alone = too_much_waiting(seen);
        }
        if (me == 0) went_alone = alone;
    }
    return went_alone;
}

}  // namespace parode::omp
