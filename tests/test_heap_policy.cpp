// The process's heap policy (util/heap_policy.hpp): once a pipeline exists,
// a block of 1 MiB or more has a mapping of its own even after a larger
// mapped block was freed. glibc's default would have raised its threshold to
// the freed block's size and served the next one from the heap, whose holes
// stay resident (a rank's peak grew with the steps and the ranks).
// Trade-off: glibc only, and not under AddressSanitizer, whose allocator
// mallinfo2 does not see; a threshold the user gives glibc wins (skip).
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "test_support.hpp"
#include "util/heap_policy.hpp"

using namespace parode;

namespace {

#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
// Bytes in mapped blocks while a block of `bytes` is held, minus before.
std::size_t mapped_growth(std::size_t bytes) {
    const std::size_t before = mallinfo2().hblkhd;
    void* volatile p = std::malloc(bytes);
    std::memset(p, 1, 64);
    const std::size_t during = mallinfo2().hblkhd;
    std::free(p);
    return during - before;
}
#endif

TEST(HeapPolicy, LargeBlocksStayMappedAfterALargerOneIsFreed) {
#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
    if (user_mmap_threshold()) GTEST_SKIP() << "the user's mmap threshold is glibc's, not ours";
    const Scene sc = test::repo_scene("jobs/scenes/tennis.toml", {"catoms.count=200"});
    Pipeline p(sc, RunOptions{});
    p.step();
    EXPECT_GE(mapped_growth(std::size_t{8} << 20), std::size_t{8} << 20);  // frees a mapped 8 MiB block
    const std::size_t medium = kMmapThreshold + (kMmapThreshold >> 1);
    EXPECT_GE(mapped_growth(medium), medium) << "a block of " << medium << " bytes came from the heap";
#else
    GTEST_SKIP() << "glibc's allocator only";
#endif
}

}  // namespace
