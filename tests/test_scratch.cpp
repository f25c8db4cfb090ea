// Scratch vectors' page advice (util/scratch.hpp): huge pages for the whole
// buffer, or with Room::Small (the contacts) for the room a call asks for and
// small pages for the growth room beyond it, read back from the kernel's own
// account of the mapping (/proc/self/smaps, VmFlags "hg").
// Trade-off: Linux only, and skipped where the kernel refuses the advice.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "page_advice.hpp"
#include "util/scratch.hpp"

namespace parode {
namespace {

using test::advised;
using test::huge_pages_supported;

TEST(ScratchVectors, SmallRoomHugePagesForTheRoomAskedSmallPagesForTheGrowthRoom) {
    if (!huge_pages_wanted() || !huge_pages_supported()) GTEST_SKIP() << "no huge-page advice here";
    std::vector<std::uint8_t> v;
    const std::size_t asked = 5 * kHugePage + 12345;
    scratch_resize(v, asked, Room::Small);  // room for twice as much
    ASSERT_GE(v.capacity(), 2 * asked);
    const auto a = reinterpret_cast<std::uintptr_t>(v.data());
    const std::uintptr_t last_asked = a + asked - 1;
    const std::uintptr_t first_page = huge_page_up(a);
    const std::uintptr_t past_asked = huge_page_up(last_asked + 1);  // the page after the last byte asked
    EXPECT_TRUE(advised(first_page));
    EXPECT_TRUE(advised(last_asked)) << "the page holding the last byte asked";
    EXPECT_FALSE(advised(past_asked)) << "growth room";
    EXPECT_FALSE(advised(a + v.capacity() - 1)) << "growth room";
}

TEST(ScratchVectors, HugeRoomHugePagesThroughout) {
    if (!huge_pages_wanted() || !huge_pages_supported()) GTEST_SKIP() << "no huge-page advice here";
    std::vector<std::uint8_t> v;
    const std::size_t asked = 5 * kHugePage + 12345;
    scratch_resize(v, asked);
    const auto a = reinterpret_cast<std::uintptr_t>(v.data());
    const std::uintptr_t last_page = (a + v.capacity()) & ~(kHugePage - 1);  // the last whole 2 MB page
    EXPECT_TRUE(advised(huge_page_up(a)));
    EXPECT_TRUE(advised(last_page - 1));
}

}  // namespace
}  // namespace parode
