// Transparent huge pages for the large per-step arrays. At a million catoms the
// solver and the collider walk hundreds of megabytes in an order the bodies'
// cells set, not the addresses': with 4 KB pages most of those reads miss the
// TLB, and every growth of a buffer faults it in 4 KB at a time. Advising
// MADV_HUGEPAGE on a buffer's 2 MB-aligned interior lets the kernel back it
// with 2 MB pages where the system allows (the default "madvise" mode).
// Trade-off: a huge page is zeroed whole on first touch, so a buffer's
// resident size rounds up to 2 MB steps; below kHugeMin bytes nothing is
// advised, so small scenes are unaffected.
#pragma once
#include <cstddef>
#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace parode {

constexpr std::size_t kHugePage = std::size_t{2} << 20;
constexpr std::size_t kHugeMin = 2 * kHugePage;

inline void advise_huge_pages(const void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (bytes < kHugeMin) return;
    const auto a = reinterpret_cast<std::uintptr_t>(data);
    const std::uintptr_t begin = (a + kHugePage - 1) & ~(kHugePage - 1);
    const std::uintptr_t end = (a + bytes) & ~(kHugePage - 1);
    if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);  // advice only
#else
    (void)data;
    (void)bytes;
#endif
}

}  // namespace parode
