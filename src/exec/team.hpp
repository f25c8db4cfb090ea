// When the threaded stages of one pipeline use their threads. Two rules,
// neither of which can change a result (every stage gives the same bits on
// any thread count):
// - Size: a loop or stage below its measured crossover runs on one thread
//   (a parallel region costs a few microseconds, more than it saves on small
//   scenes; the crossovers are in docs/performance.md, "Threads and small
//   scenes"). ExecutionConfig::min_parallel overrides every crossover.
// - Sharing: when another process holds one of our cores, every barrier waits
//   for a thread the kernel has descheduled. The threaded sweeps of the
//   contact solver time their threads' work and waits at every colour
//   barrier; when a thread waits over a millisecond and so long that one
//   thread doing the whole team's work would have been done sooner (and the
//   same holds for its waits over the sweep call so far: a single wait is as
//   likely the kernel's noise), the rest of the step's sweeps run on one
//   thread, and so do all other stages from then on (barrier_says_shared). On a
//   distributed run the wait for the other processes' corrections after each
//   colour is not counted: it is their pace, not a core taken from this one.
//   Only the solver's iterations try threads again, on a later step (after
//   1, 2, 4, ... 16 steps while the sharing lasts); when a try succeeds every
//   stage has its threads back.
// A Team belongs to one Execution (exec/execution.hpp), so two pipelines in
// one process keep their own verdicts and thread counts.
// Trade-off: a shared machine loses waits as long as the work per try, instead
// of a descheduled thread's time slice at every barrier of every stage; a
// machine that frees up waits up to 16 steps to get its threads back.
#pragma once
#include <cstddef>

namespace parode {

// The sharing rule of one thread of a team of `team` at a barrier: it worked
// `work` seconds and then waited `wait` for the others; over the call so far
// `total_work` and `total_wait`. Shared when the wait is over 1 ms (a
// descheduled thread, not a slow wake-up or an uneven split: a time slice is
// several) and exceeds the other threads' work, estimated as (team - 1) times
// its own, and the totals do too: then one thread alone would have finished
// sooner. On two threads that is a wait longer than the work; on sixteen,
// fifteen times the work, because there waits as long as the work are
// ordinary (0.4 ms of work a colour a thread at 10^6 catoms, and a barrier of
// 16 threads in a virtual machine costs as much): the rule of two threads
// applied to sixteen sent a third of the 16-thread runs to one thread.
bool barrier_says_shared(double work, double wait, double total_work, double total_wait, int team);

class Team {
public:
    // `threads` (>= 1) threads; `min_parallel` >= 0 replaces every crossover;
    // not `adaptive`: sharing verdicts are ignored, threads always tried (to
    // measure crossovers).
    Team(int threads, long min_parallel, bool adaptive);
    // Threads for a loop of `items` items whose crossover is `crossover` items
    // (one while the cores are shared).
    int threads(std::size_t items, std::size_t crossover) const;
    // The same for the solver's sweeps, which try threads again now and then.
    int sweep_threads(std::size_t items, std::size_t crossover) const;
    int max_threads() const { return threads_; }
    // The crossover in force for a loop whose measured one is `crossover`.
    long crossover(long measured) const { return min_parallel_ >= 0 ? min_parallel_ : measured; }
    // Sharing: whether this step may try threads; the sweep's verdict.
    bool try_threads() const { return !shared_ || wait_ == 0; }
    void verdict(bool shared);
    bool shared() const { return shared_; }
    // The solver's step begins and ends (a step run alone counts down the wait).
    void begin_step() { alone_ = !try_threads(); }
    void end_step() {
        if (alone_ && wait_ > 0) --wait_;
    }

private:
    int threads_ = 1;
    long min_parallel_ = -1;
    bool adaptive_ = true;
    bool shared_ = false;
    bool alone_ = false;  // this step runs on one thread
    int wait_ = 0;        // steps to run alone before the next try
    int backoff_ = 1;     // the wait after the next failed try
};

}  // namespace parode
