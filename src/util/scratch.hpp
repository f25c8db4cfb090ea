// Sizing of per-step scratch vectors (rebuilt from scratch each step, so
// their old contents need not survive a growth). Growing frees the old buffer
// before allocating the new one, with twice the room asked: a vector whose
// size creeps up from step to step (the contacts of a collapsing pile grow by
// a third over its first ten steps) reallocates about once and never holds
// two copies at once, which would set the run's peak memory; capacity not yet
// touched costs no resident memory. Each reallocation faults the whole buffer
// in afresh (measured at 10^6 catoms, steps 4 to 9: 318 fresh 2 MB pages with
// a quarter's room, 56 with twice; peak memory unchanged).
// Trade-off: the contents are lost on growth, so these are only for vectors
// every element of which the caller writes after sizing.
#pragma once
#include <cstddef>

#include "huge_pages.hpp"

namespace parode {

// Room for n elements: a fresh buffer (the old one freed first) when n
// exceeds the capacity; the contents are then lost.
template <class V>
void scratch_reserve(V& v, std::size_t n) {
    if (n <= v.capacity()) return;
    V().swap(v);
    v.reserve(2 * n);
    advise_huge_pages(v.data(), v.capacity() * sizeof(*v.data()));
}

template <class V>
void scratch_resize(V& v, std::size_t n) {
    scratch_reserve(v, n);
    v.resize(n);
}

template <class V, class T>
void scratch_assign(V& v, std::size_t n, const T& value) {
    scratch_reserve(v, n);
    v.assign(n, value);
}

}  // namespace parode
