// Timing of collision backends on one identical state: every (backend, threads)
// configuration collides the same geoms, configurations alternate within each
// repetition, in an order rotated from one repetition to the next (so drift in
// machine state and cache warmth hit all alike), and the median per
// configuration is reported with the contact count and digest of its result.
// ODE's own backends need their geoms in a space of their kind: the top-level
// geoms of `space` are moved (untimed) into a scratch space of the kind each
// backend asks for, and moved back at the end; their order in the space's list
// may change, which changes no result.
// Trade-off: moving geoms between spaces costs time outside the measurement but
// keeps the caller's setup to one populated space.
#pragma once
#include <ode/ode.h>

#include <cstdint>
#include <string>
#include <vector>

namespace parode::omp {

struct BenchResult {
    std::string backend;
    int threads = 1;          // team size used (1 for serial backends)
    double median_s = 0;      // median seconds per collide call
    double min_s = 0;
    std::size_t contacts = 0;
    std::uint64_t digest = 0;  // contact_digest of the last call
};

// Times backend->collide for every backend name (from BackendRegistry) and, for
// backends that use threads, every entry of `threads` (0 = default team).
// `repetitions` timed calls per configuration after one warm-up call.
std::vector<BenchResult> bench_collide(dSpaceID space, const std::vector<std::string>& backends,
                                       const std::vector<int>& threads, int max_contacts,
                                       int repetitions);

// What the machine itself gives: the speedup of a compute-bound loop (no
// memory traffic) on `threads` threads over one. On a shared or oversubscribed
// machine it falls below `threads`, and scaling results should be read
// against it.
double machine_speedup(int threads);

}  // namespace parode::omp
