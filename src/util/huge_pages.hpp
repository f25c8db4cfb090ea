// Transparent huge pages for the large per-step arrays. At a million catoms the
// solver and the collider walk hundreds of megabytes in an order the bodies'
// cells set, not the addresses': with 4 KB pages most of those reads miss the
// TLB, and every growth of a buffer faults it in 4 KB at a time. Advising
// MADV_HUGEPAGE on a buffer's 2 MB-aligned interior lets the kernel back it
// with 2 MB pages where the system allows (the default "madvise" mode).
// Trade-off: a huge page is zeroed whole on first touch, so a buffer's
// resident size rounds up to 2 MB steps; below kHugeMin bytes nothing is
// advised, so small scenes are unaffected. PARODE_HUGE_PAGES=0 in the
// environment turns the advice off (for systems where huge pages cost more
// than they save, e.g. with memory compaction stalls); 1 or unset: on.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace parode {

constexpr std::size_t kHugePage = std::size_t{2} << 20;
constexpr std::size_t kHugeMin = 2 * kHugePage;

// The value of PARODE_HUGE_PAGES (null: unset) as a switch; throws
// std::invalid_argument naming the variable unless it is 0, 1 or empty.
inline bool parse_huge_pages(const char* value) {
    const std::string v = value ? value : "";
    if (v.empty() || v == "1") return true;
    if (v == "0") return false;
    throw std::invalid_argument("PARODE_HUGE_PAGES=" + v + ": expected 0 (no huge-page advice) or 1 (the default)");
}

// Whether buffers are advised huge pages: PARODE_HUGE_PAGES, read once.
inline bool huge_pages_wanted() {
    static const bool wanted = parse_huge_pages(std::getenv("PARODE_HUGE_PAGES"));
    return wanted;
}

// The first 2 MB page boundary at or after address a.
inline std::uintptr_t huge_page_up(std::uintptr_t a) { return (a + kHugePage - 1) & ~(kHugePage - 1); }

inline void advise_huge_pages(const void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (bytes < kHugeMin || !huge_pages_wanted()) return;
    const auto a = reinterpret_cast<std::uintptr_t>(data);
    const std::uintptr_t begin = huge_page_up(a);
    const std::uintptr_t end = (a + bytes) & ~(kHugePage - 1);
    if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);  // advice only
#else
    (void)data;
    (void)bytes;
#endif
}

// Huge pages for the first `used` bytes of a buffer of `capacity` bytes,
// through the end of the 2 MB page holding the last of them; the room beyond
// is left to small pages.
inline void advise_huge_pages_through(const void* data, std::size_t used, std::size_t capacity) {
    const auto a = reinterpret_cast<std::uintptr_t>(data);
    const std::size_t through = huge_page_up(a + used) - a;
    advise_huge_pages(data, through < capacity ? through : capacity);
}

}  // namespace parode
