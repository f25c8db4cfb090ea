// Sizing of per-step scratch vectors (rebuilt from scratch each step, so
// their old contents need not survive a growth). Growing frees the old buffer
// before allocating the new one, with twice the room asked: a vector whose
// size creeps up from step to step (the contacts of a collapsing pile grow by
// a third over its first ten steps) reallocates about once and never holds
// two copies at once, which would set the run's peak memory; capacity not yet
// touched costs no resident memory. Each reallocation faults the whole buffer
// in afresh (measured at 10^6 catoms, steps 4 to 9: 318 fresh 2 MB pages with
// a quarter's room, 56 with twice; peak memory unchanged).
// Buffers are advised huge pages whole (util/huge_pages.hpp); Room::Small
// advises only the room asked, leaving the growth room beyond it to 4 KB
// pages, for a buffer written in order whose size creeps up a little every
// step (the contacts): there a fresh 2 MB page is zeroed whole for a few
// records, inside the measured step. On a VM that hands free memory back to
// its host, a fresh 2 MB page took 4 ms to fault against 0.8 ms in 4 KB
// pages (0.2 ms for a recycled one); the contacts' merge at 10^6 catoms took
// 14-15 ms a later step, 9 with small pages for its growth (docs/performance/million-catoms.md,
// "Growth room in small pages").
// Trade-off: the contents are lost on growth, so these are only for vectors
// every element of which the caller writes after sizing; a Room::Small
// buffer's growth, once used, is read through 4 KB pages.
#pragma once
#include <cstddef>

#include "util/huge_pages.hpp"

namespace parode {

// Which pages the room beyond the size asked gets.
enum class Room { Huge, Small };

// Room for n elements: a fresh buffer (the old one freed first) when n
// exceeds the capacity; the contents are then lost. Room::Small leaves the
// growth room beyond n to small pages.
template <class V>
void scratch_reserve(V& v, std::size_t n, Room room = Room::Huge) {
    if (n <= v.capacity()) return;
    V().swap(v);
    v.reserve(2 * n);
    const std::size_t size = sizeof(*v.data());
    if (room == Room::Small) {
        advise_huge_pages_through(v.data(), n * size, v.capacity() * size);
    } else {
        advise_huge_pages(v.data(), v.capacity() * size);
    }
}

template <class V>
void scratch_resize(V& v, std::size_t n, Room room = Room::Huge) {
    scratch_reserve(v, n, room);
    v.resize(n);
}

template <class V, class T>
void scratch_assign(V& v, std::size_t n, const T& value) {
    scratch_reserve(v, n);
    v.assign(n, value);
}

}  // namespace parode
