// Threaded sweeps of the contact solver (see parallel_solver.hpp).
#include "omp/solver/parallel_solver.hpp"

#include <algorithm>
#include <atomic>
#include <exception>

#include "exec/team.hpp"
#include "omp/runtime/task_split.hpp"
#include "util/substages.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace parode::omp {

void ParallelContactSolver::step(World& world, const ContactBuffer& contacts) {
    execution().team().begin_step();
    ContactSolver::step(world, contacts);
    execution().team().end_step();
}

namespace {

// Where the cost measured on ranges [share[j], share[j+1]) (seconds[j] each,
// spread evenly over its share) reaches `part` of the whole, as a share.
double cost_quantile(const double* share, const double* seconds, std::size_t t, double part) {
    double total = 0;
    for (std::size_t j = 0; j < t; ++j) total += seconds[j];
    double want = part * total;
    for (std::size_t j = 0; j < t; ++j) {
        const double width = share[j + 1] - share[j];
        if (width <= 0) continue;
        if (seconds[j] >= want) return share[j] + width * (seconds[j] > 0 ? want / seconds[j] : 0.0);
        want -= seconds[j];
    }
    return 1.0;
}

}  // namespace

// Per phase (a colour's boundary cells, then its interior cells), one cell
// range per thread holding about equal shares of the time measured on the
// previous call (of contacts, without one).
void ParallelContactSolver::split(int team) {
    const SweepLayout& L = layout();
    const std::size_t t = static_cast<std::size_t>(team), stride = t + 1;
    const bool measured = share_.size() == kPhases * stride;
    ranges_.assign(kPhases * stride, 0);
    std::vector<double> share(kPhases * stride, 0.0);
    for (int ph = 0; ph < kPhases; ++ph) {
        const int c = ph / 2;
        const std::size_t b = ph % 2 ? L.boundary_end(c) : L.colour_begin(c);
        const std::size_t e = ph % 2 ? L.colour_end(c) : L.boundary_end(c);
        const std::size_t at = static_cast<std::size_t>(ph) * stride;
        const std::size_t p0 = L.cell_begin(b), p1 = L.cell_begin(e);
        std::size_t* r = ranges_.data() + at;
        double total = 0;
        for (std::size_t j = 0; measured && j < t; ++j) total += seconds_[at + j];
        r[0] = b;
        r[t] = e;
        for (std::size_t j = 1; j < t; ++j) {
            const double part = static_cast<double>(j) / static_cast<double>(t);
            const double g = total > 0 ? cost_quantile(&share_[at], &seconds_[at], t, part) : part;
            const std::size_t target = p0 + static_cast<std::size_t>(static_cast<double>(p1 - p0) * g);
            std::size_t lo = r[j - 1], hi = e;  // first cell starting at or after target
            while (lo < hi) {
                const std::size_t mid = (lo + hi) / 2;
                if (L.cell_begin(mid) < target) lo = mid + 1;
                else hi = mid;
            }
            r[j] = lo;
        }
        for (std::size_t j = 0; j <= t; ++j) {
            share[at + j] = p1 > p0 ? static_cast<double>(L.cell_begin(r[j]) - p0) / static_cast<double>(p1 - p0) : 0.0;
        }
    }
    share_.swap(share);
    seconds_.assign(kPhases * stride, 0.0);
}

void ParallelContactSolver::sweep(int passes, bool warm) {
    Team& team = execution().team();
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

// The threads relax their ranges colour by colour: on a distributed run the
// colour's boundary cells, a barrier, the master posts the corrections while
// every thread goes on with the interior cells, a barrier, the master
// completes the exchange, a barrier; on one process the colour's cells and a
// barrier. Steps (colours of all passes) are numbered; a thread that waited too
// long at the barrier after step k (barrier_says_shared) sets `alone_at` to k + 2 (the
// least such value wins). After the barrier of step k - 1 every thread sees every value
// written before it, and values written after it are at least k + 1, so all
// threads agree whether step k runs alone: from then on thread 0 runs the
// remaining steps by itself and the others leave. Returns whether it did.
bool ParallelContactSolver::sweep_threaded(int passes, bool warm, int team) {
    const std::size_t stride = static_cast<std::size_t>(team) + 1;
    const long steps = static_cast<long>(passes) * kColours;
    std::atomic<long> alone_at{steps};
    std::exception_ptr failed;  // the exchange's error: every thread leaves, then it is thrown here
#pragma omp parallel num_threads(team) shared(alone_at, failed)
    {
        double total_work = 0, total_wait = 0;
        const std::size_t me = static_cast<std::size_t>(thread_index());
        for (long k = 0; k < steps; ++k) {
            const int c = static_cast<int>(k % kColours);
            if (alone_at.load(std::memory_order_acquire) <= k) {
                if (me == 0) {
                    try {
                        finish_alone(k, steps, warm);
                    } catch (...) {
                        failed = std::current_exception();
                    }
                }
                break;
            }
            const PhaseTimes pt = colour_threaded(c, warm, me, stride, failed);
            if (failed) break;
            total_work += pt.work;
            if (k == 0) continue;  // the first barrier also waits for the threads to wake up
            total_wait += pt.wait;
            if (barrier_says_shared(pt.work, pt.wait, total_work, total_wait, team)) {
                long want = k + 2, have = alone_at.load(std::memory_order_relaxed);
                while (want < have && !alone_at.compare_exchange_weak(have, want, std::memory_order_release)) {
                }
            }
        }
    }
    if (failed) std::rethrow_exception(failed);
    return alone_at.load() < steps;
}

// Thread `me`'s part of colour c (inside the sweep's parallel region): its
// seconds of work and of waiting for the other threads. The exchange's wait
// is the other processes' pace, not a core taken from this one: not counted.
ParallelContactSolver::PhaseTimes ParallelContactSolver::colour_threaded(int c, bool warm, std::size_t me,
                                                                         std::size_t stride, std::exception_ptr& failed) {
    const auto cells = [&](int ph) {
        const std::size_t* r = ranges_.data() + static_cast<std::size_t>(ph) * stride;
        const double t0 = now_seconds();
        if (warm) warm_cells(r[me], r[me + 1]);
        else relax_cells(r[me], r[me + 1]);
        const double t1 = now_seconds();
        seconds_[static_cast<std::size_t>(ph) * stride + me] += t1 - t0;
        return t1 - t0;
    };
    const auto cu = static_cast<std::size_t>(c);
    PhaseTimes pt;
    const double start = now_seconds();
    if (exchanging()) {  // one thread talks to the other processes (MPI_THREAD_FUNNELED)
        pt.work += cells(2 * c);
        double t = now_seconds();
#pragma omp barrier
        pt.wait += now_seconds() - t;
#pragma omp master
        try {
            post_after_boundary(c);
        } catch (...) {  // an exception may not leave a parallel region
            failed = std::current_exception();
        }
    }
    pt.work += cells(2 * c + 1);  // the other threads start at once; the master after posting
    double t = now_seconds();
#pragma omp barrier
    const double done = now_seconds();
    pt.wait += done - t;
#pragma omp master
    {
        colour_times_mut().compute[cu] += done - start;
        if (exchanging() && !failed) {
            try {
                complete_after_interior(c);
            } catch (...) {
                failed = std::current_exception();
            }
            colour_times_mut().wait[cu] += now_seconds() - done;
        }
    }
    if (exchanging()) {
#pragma omp barrier
    }
    return pt;
}

// The adaptive solver's sweep of listed cells on the team's threads: per
// colour its listed boundary cells cut among the threads by contacts, a
// barrier, the master posts the corrections while every thread relaxes its
// share of the listed interior cells, a barrier, the master completes the
// exchange, a barrier (without an exchange: the two classes and one barrier).
// Cells of one colour touch disjoint bodies and each cell's change is its
// own, so the split decides nothing but who relaxes what.
void ParallelContactSolver::list_sweep() {
    Team& team = execution().team();
    const int t = team.threads(listed_contacts(listed_begin(2 * kColours)), kSweepCrossover);
    if (t <= 1) {
        ContactSolver::list_sweep();
        return;
    }
    std::exception_ptr failed;
#pragma omp parallel num_threads(t) shared(failed)
    {
        const auto me = static_cast<std::size_t>(thread_index()), n = static_cast<std::size_t>(t);
        for (int c = 0; c < kColours && !failed; ++c) {
            if (!exchanging()) {  // both classes at once
                relax_listed_share(listed_begin(2 * c), listed_begin(2 * c + 2), me, n);
#pragma omp barrier
                continue;
            }
            relax_listed_share(listed_begin(2 * c), listed_begin(2 * c + 1), me, n);
#pragma omp barrier
#pragma omp master
            try {
                post_after_boundary(c);
            } catch (...) {  // an exception may not leave a parallel region
                failed = std::current_exception();
            }
            relax_listed_share(listed_begin(2 * c + 1), listed_begin(2 * c + 2), me, n);
#pragma omp barrier
#pragma omp master
            if (!failed) {
                try {
                    complete_after_interior(c);
                } catch (...) {
                    failed = std::current_exception();
                }
            }
#pragma omp barrier
        }
    }
    if (failed) std::rethrow_exception(failed);
}

void ParallelContactSolver::relax_listed_share(std::size_t a0, std::size_t a1, std::size_t me, std::size_t team) {
    const std::size_t c0 = listed_contacts(a0), c1 = listed_contacts(a1);
    const auto first = [&](std::size_t j) {  // the first entry at or after share j's start
        return listed_entry_at(a0, a1, c0 + (c1 - c0) * j / team);
    };
    relax_listed(me == 0 ? a0 : first(me), me + 1 == team ? a1 : first(me + 1));
}

// Steps [from, steps) on this thread: the colours of the pass under way, then
// whole passes.
void ParallelContactSolver::finish_alone(long from, long steps, bool warm) {
    for (long k = from; k < steps; ++k) colour_alone(static_cast<int>(k % kColours), warm);
}

}  // namespace parode::omp
