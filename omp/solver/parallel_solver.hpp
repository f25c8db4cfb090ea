// The "parallel" solver: ContactSolver (src/solve/contact_solver) with its
// sweeps on OpenMP threads; its other loops go through the OpenMP loop runner.
// A sweep runs in one parallel region: the 8 colours in sequence, the cells of
// a colour cut into one contiguous range per thread (cells are sorted in
// space, so each thread keeps its bodies in cache; cells of one colour touch
// disjoint bodies), a barrier after each colour. The ranges hold equal shares
// of the time the threads measured on the previous sweep call (equal numbers
// of contacts on the first): a contact's cost varies along a colour by 2x and
// more at a million catoms (cache misses, plane against sphere rows), and
// // equal contact counts left one thread waiting a third of the sweep. The
// threads time their work and their waits: when a thread has waited at a
// barrier longer than it worked and over a millisecond, and in all the call
// so far has waited longer than it worked (another process holds a core and
// the kernel deschedules a thread), the rest of the step runs on one thread,
// two colours later (exec/team.hpp). The team is the execution's: the
// solver's threads and verdicts are its pipeline's own.
// Results are bit for bit those of the serial "pgs" for any thread count.
// Trade-off: 8 barriers per iteration (160 a step at 20 iterations), worth it
// above the crossover (docs/performance/threads-and-small-scenes.md); the
// timing costs three clock reads a colour,
// and a shared core still costs waits as long as the work before the verdict.
#pragma once
#include <exception>
#include <vector>

#include "solve/contact_solver.hpp"

namespace parode::omp {

class ParallelContactSolver final : public ContactSolver {
public:
    using ContactSolver::ContactSolver;
    std::string name() const override { return adaptive() ? "adaptive/omp" : "parallel"; }
    void step(World& world, const ContactBuffer& contacts) override;

private:
    void list_sweep() override;
    // Thread `me` of `team`'s share of listed entries [a0, a1), by contacts.
    void relax_listed_share(std::size_t a0, std::size_t a1, std::size_t me, std::size_t team);
    // Phases: colour c's boundary cells (2c), then its interior cells (2c + 1).
    static constexpr int kPhases = 2 * kColours;
    struct PhaseTimes {
        double work = 0, wait = 0;
    };
    void sweep(int passes, bool warm) override;
    void split(int team);
    bool sweep_threaded(int passes, bool warm, int team);
    PhaseTimes colour_threaded(int c, bool warm, std::size_t me, std::size_t stride, std::exception_ptr& failed);
    void finish_alone(long from, long steps, bool warm);

    std::vector<std::size_t> ranges_;  // phase-major: first cell of each thread's range, + end
    // Phase-major, per thread: where its range began and ended as a share of
    // the phase's contacts, and the seconds it worked there (this call).
    std::vector<double> share_, seconds_;
};

// Contacts below which the sweeps run on one thread (measured:
// docs/performance/threads-and-small-scenes.md).
constexpr std::size_t kSweepCrossover = 1500;

}  // namespace parode::omp
