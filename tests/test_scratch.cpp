// Scratch vectors' and pool slots' page advice (util/scratch.hpp,
// util/scratch_pool.hpp): huge pages for the room a call asks for, small
// pages for the growth room beyond it, read back from the kernel's own
// account of the mapping (/proc/self/smaps, VmFlags "hg").
// Trade-off: Linux only, and skipped where the kernel refuses the advice.
#include <gtest/gtest.h>

#include <sys/mman.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "util/scratch.hpp"
#include "util/scratch_pool.hpp"

namespace parode {
namespace {

struct Mapping {
    std::uintptr_t begin = 0, end = 0;
    bool huge = false;  // advised MADV_HUGEPAGE
};

std::vector<Mapping> mappings() {
    std::vector<Mapping> out;
    std::ifstream smaps("/proc/self/smaps");
    std::string line;
    while (std::getline(smaps, line)) {
        std::uintptr_t b = 0, e = 0;
        char dash = 0;
        std::istringstream range(line);
        if (range >> std::hex >> b >> dash >> e && dash == '-' && line.find(' ') != std::string::npos &&
            line.find(':') > line.find(' ')) {
            out.push_back(Mapping{b, e, false});
        } else if (line.rfind("VmFlags:", 0) == 0 && !out.empty()) {
            out.back().huge = (" " + line.substr(8) + " ").find(" hg ") != std::string::npos;
        }
    }
    return out;
}

// Whether the kernel advises huge pages at all (MADV_HUGEPAGE accepted).
bool huge_pages_supported() {
    void* p = mmap(nullptr, 2 * kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) return false;
    const bool ok = madvise(p, 2 * kHugePage, MADV_HUGEPAGE) == 0;
    munmap(p, 2 * kHugePage);
    return ok;
}

// Whether the byte at `a` lies in a mapping advised huge pages.
bool advised(std::uintptr_t a) {
    for (const Mapping& m : mappings()) {
        if (a >= m.begin && a < m.end) return m.huge;
    }
    return false;
}

TEST(ScratchVectors, HugePagesForTheRoomAskedSmallPagesForTheGrowthRoom) {
    if (!huge_pages_wanted() || !huge_pages_supported()) GTEST_SKIP() << "no huge-page advice here";
    std::vector<std::uint8_t> v;
    const std::size_t asked = 5 * kHugePage + 12345;
    scratch_resize(v, asked);  // room for twice as much
    ASSERT_GE(v.capacity(), 2 * asked);
    const auto a = reinterpret_cast<std::uintptr_t>(v.data());
    const std::uintptr_t last_asked = a + asked - 1;
    const std::uintptr_t first_page = (a + kHugePage - 1) & ~(kHugePage - 1);
    const std::uintptr_t past_asked = (last_asked + kHugePage) & ~(kHugePage - 1);  // the page after the last byte asked
    EXPECT_TRUE(advised(first_page));
    EXPECT_TRUE(advised(last_asked)) << "the page holding the last byte asked";
    EXPECT_FALSE(advised(past_asked)) << "growth room";
    EXPECT_FALSE(advised(a + v.capacity() - 1)) << "growth room";
}

TEST(ScratchPool, HugePagesForTheBytesAskedSmallPagesForTheGrowthRoom) {
    if (!huge_pages_wanted() || !huge_pages_supported()) GTEST_SKIP() << "no huge-page advice here";
    ScratchPool pool;
    const std::size_t asked = 5 * kHugePage + 12345;
    const auto a = reinterpret_cast<std::uintptr_t>(pool.take(kSlotGeoms, asked));  // room for twice as much
    const std::uintptr_t last_asked = a + asked - 1;
    EXPECT_TRUE(advised((a + kHugePage - 1) & ~(kHugePage - 1)));
    EXPECT_TRUE(advised(last_asked)) << "the page holding the last byte asked";
    EXPECT_FALSE(advised((last_asked + kHugePage) & ~(kHugePage - 1))) << "growth room";
    EXPECT_FALSE(advised(a + 2 * asked - 1)) << "growth room";
}

}  // namespace
}  // namespace parode
