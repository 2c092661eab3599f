#include "monitor/small_blocks.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

namespace plexus::daemon::monitor {
namespace {

TEST(SmallBlocks_test, AGivenBlockIsTakenAgainForTheSameSizeClass) {
    SmallBlocks blocks;
    void* first = blocks.take(20);
    ASSERT_NE(first, nullptr);
    std::memset(first, 0xab, 20);
    blocks.give(first, 20);
    EXPECT_EQ(blocks.take(32), first) << "20 and 32 bytes are the same 16-byte class";
    void* other = blocks.take(33);
    EXPECT_NE(other, first);
    blocks.give(other, 33);
    blocks.give(first, 32);
}

TEST(SmallBlocks_test, LargeBlocksAreNotKept) {
    SmallBlocks blocks;
    void* large = blocks.take(SmallBlocks::largest + 1);
    ASSERT_NE(large, nullptr);
    blocks.give(large, SmallBlocks::largest + 1);  // freed, not cached: nothing to check but no leak
    EXPECT_FALSE(SmallBlocks::same_class(SmallBlocks::largest, SmallBlocks::largest + 1));
    EXPECT_TRUE(SmallBlocks::same_class(1, 16));
    EXPECT_FALSE(SmallBlocks::same_class(16, 17));
}

TEST(SmallBlocks_test, KeepsAtMostABoundedNumberPerClass) {
    SmallBlocks blocks;
    std::vector<void*> taken;
    for (int i = 0; i < 1000; ++i)
        taken.push_back(blocks.take(64));
    for (void* block : taken)
        blocks.give(block, 64);
    // Only the most recently given blocks come back; the rest went to free(). Taking 1000 again
    // must still work (from the cache first, then from malloc).
    std::vector<void*> again;
    for (int i = 0; i < 1000; ++i) {
        again.push_back(blocks.take(64));
        ASSERT_NE(again.back(), nullptr);
    }
    for (void* block : again)
        blocks.give(block, 64);
}

}  // namespace
}  // namespace plexus::daemon::monitor
