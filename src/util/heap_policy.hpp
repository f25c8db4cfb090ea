// The process's heap policy for long runs of large buffers (glibc only).
// - fix_mmap_threshold(): allocations of 1 MiB and more get mappings of
//   their own, returned to the system when freed. glibc's default threshold
//   starts at 128 kB and rises to the size of each mapped block freed (up to
//   32 MiB), after which the step's buffers of a few MiB come from the heap,
//   whose freed holes stay resident: a rank's peak grew with the steps and
//   with the number of ranks (more, differently sized message and ghost
//   buffers). Measured peak, 10^6 catoms a rank, 2 steps, 1/2/4/8 ranks:
//   1,760/1,846/1,879/1,863 MiB with the rising threshold, 1,734/1,794/
//   1,810/1,815 with it fixed. A threshold the user gives glibc
//   (MALLOC_MMAP_THRESHOLD_, or mmap_threshold in GLIBC_TUNABLES) is left
//   alone.
// - release_free_heap(): hands the freed pages of the set-up's temporaries
//   (the root's gathered cells and partition, the migration's messages) back
//   once before the first step: the root carried ~2.7 MB more at its peak
//   than a rank of its size (8 ranks of 50,000 catoms).
// Trade-off: the few buffers of 1 MiB or more a step frees and allocates
// again are mapped and faulted in each time (the ghost exchange's were: 2
// ranks of 10^6 catoms took 4,090 page faults a step against 1,670, 1-2 ms
// of 600; kept as members instead, they were resident at the solve's peak;
// they now lie in the scratch pool, mpi_domain.cpp); one walk of the heap at
// start-up (0.5 ms on each of 2 ranks of 10^6 catoms).
#pragma once
#include <cstdlib>
#include <cstring>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace parode {

constexpr int kMmapThreshold = 1 << 20;

// Whether the user gave glibc an mmap threshold of their own.
inline bool user_mmap_threshold() {
    const char* tunables = std::getenv("GLIBC_TUNABLES");
    return std::getenv("MALLOC_MMAP_THRESHOLD_") || (tunables && std::strstr(tunables, "mmap_threshold"));
}

inline void fix_mmap_threshold() {
#if defined(__GLIBC__)
    if (!user_mmap_threshold()) mallopt(M_MMAP_THRESHOLD, kMmapThreshold);
#endif
}

inline void release_free_heap() {
#if defined(__GLIBC__)
    malloc_trim(0);
#endif
}

}  // namespace parode
