// Hands the heap's free pages back to the system once a run's set-up is done.
// The set-up's temporaries (the root's gathered cells and partition, the
// migration's messages) are freed before the first step, but glibc keeps the
// pages they touched resident while the step's large buffers come from fresh
// mappings: the root carried ~2.7 MB more at its peak than a rank of its size
// (8 ranks of 50,000 catoms). Trade-off: one walk of the heap at start-up
// (0.5 ms on each of 2 ranks of 10^6 catoms, 0.02 ms on one process of 10^6,
// measured by wrapping the call); nothing elsewhere than glibc.
#pragma once

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace parode {

inline void release_free_heap() {
#if defined(__GLIBC__)
    malloc_trim(0);
#endif
}

}  // namespace parode
