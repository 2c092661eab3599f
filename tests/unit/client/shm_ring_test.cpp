// The slot allocator of a writer's shared-memory region (shm_ring.hpp): slots never overlap, come
// back in any order, and a full region says so instead of handing out a slot in use.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "../../../client/src/shm_ring.hpp"

namespace plexus::detail {
namespace {

constexpr std::size_t mib = 1024 * 1024;

TEST(ShmRing_test, SlotsFollowEachOtherUntilTheRegionIsFull) {
    ShmRing ring(4 * mib);
    EXPECT_EQ(ring.allocate(mib), 0u);
    EXPECT_EQ(ring.allocate(mib), mib);
    EXPECT_EQ(ring.allocate(mib), 2 * mib);
    EXPECT_EQ(ring.allocate(mib), 3 * mib);
    EXPECT_FALSE(ring.allocate(1).has_value()) << "a full region handed out a slot";
    EXPECT_EQ(ring.used(), 4u);
}

TEST(ShmRing_test, AFreedSlotIsReusedWhenTheRingComesRoundToIt) {
    ShmRing ring(3 * mib);
    const auto first = ring.allocate(mib);
    const auto second = ring.allocate(mib);
    const auto third = ring.allocate(mib);
    ASSERT_TRUE(first && second && third);
    EXPECT_TRUE(ring.free(*second));  // released out of order: a reader that was faster
    EXPECT_FALSE(ring.allocate(mib).has_value()) << "the gap is not where the ring is";
    EXPECT_TRUE(ring.free(*first));
    EXPECT_EQ(ring.allocate(2 * mib), 0u) << "after wrapping, the two freed slots make one gap";
}

TEST(ShmRing_test, TooLargeEmptyAndUnknownAreRefused) {
    ShmRing ring(mib);
    EXPECT_FALSE(ring.allocate(mib + 1).has_value());
    EXPECT_FALSE(ring.allocate(0).has_value());
    EXPECT_FALSE(ring.free(12345));
    const auto slot = ring.allocate(100);
    ASSERT_TRUE(slot.has_value());
    EXPECT_TRUE(ring.free(*slot));
    EXPECT_FALSE(ring.free(*slot)) << "a slot was freed twice";
}

TEST(ShmRing_test, RandomAllocationsAndFreesNeverOverlap) {
    ShmRing ring(8 * mib);
    std::mt19937 random(3);
    std::vector<std::pair<std::size_t, std::size_t>> held;  // offset, length
    for (int step = 0; step < 20000; ++step) {
        if (!held.empty() && random() % 2 == 0) {
            const auto i = random() % held.size();
            ASSERT_TRUE(ring.free(held[i].first));
            held.erase(held.begin() + static_cast<std::ptrdiff_t>(i));
            continue;
        }
        const std::size_t length = 1 + random() % (2 * mib);
        const auto offset = ring.allocate(length);
        if (!offset)
            continue;
        ASSERT_LE(*offset + length, 8 * mib);
        for (const auto& [other, other_length] : held)
            ASSERT_TRUE(*offset + length <= other || other + other_length <= *offset) << "overlap at step " << step;
        held.emplace_back(*offset, length);
    }
}

}  // namespace
}  // namespace plexus::detail
