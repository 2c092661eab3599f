// The slot allocator of a writer's shared-memory region (shm_slots.hpp): slots never overlap, come
// back in any order, and a full region says so instead of handing out a slot in use.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "../../../client/src/shm_slots.hpp"

namespace plexus::detail {
namespace {

constexpr std::size_t slot_mib = 1024 * 1024;

TEST(ShmSlots_test, SlotsFollowEachOtherUntilTheRegionIsFull) {
    ShmSlots slots(4 * slot_mib);
    EXPECT_EQ(slots.allocate(slot_mib), 0u);
    EXPECT_EQ(slots.allocate(slot_mib), slot_mib);
    EXPECT_EQ(slots.allocate(slot_mib), 2 * slot_mib);
    EXPECT_EQ(slots.allocate(slot_mib), 3 * slot_mib);
    EXPECT_FALSE(slots.allocate(1).has_value()) << "a full region handed out a slot";
    EXPECT_EQ(slots.used(), 4u);
}

TEST(ShmSlots_test, TheLowestGapLargeEnoughIsTakenFirst) {
    ShmSlots slots(4 * slot_mib);
    const auto first = slots.allocate(slot_mib);
    const auto second = slots.allocate(slot_mib);
    const auto third = slots.allocate(slot_mib);
    ASSERT_TRUE(first && second && third);
    EXPECT_TRUE(slots.free(*second));  // released out of order: a reader that was faster
    EXPECT_EQ(slots.allocate(2 * slot_mib), std::nullopt)
        << "no gap of 2 MiB: the last MiB and the freed one are apart";
    EXPECT_EQ(slots.allocate(slot_mib), *second) << "the freed slot comes before the free end";
    EXPECT_TRUE(slots.free(*first));
    EXPECT_TRUE(slots.free(*second));
    EXPECT_EQ(slots.allocate(2 * slot_mib), 0u) << "two neighbouring freed slots make one gap";
}

TEST(ShmSlots_test, TooLargeEmptyAndUnknownAreRefused) {
    ShmSlots slots(slot_mib);
    EXPECT_FALSE(slots.allocate(slot_mib + 1).has_value());
    EXPECT_FALSE(slots.allocate(0).has_value());
    EXPECT_FALSE(slots.free(12345));
    const auto slot = slots.allocate(100);
    ASSERT_TRUE(slot.has_value());
    EXPECT_TRUE(slots.free(*slot));
    EXPECT_FALSE(slots.free(*slot)) << "a slot was freed twice";
}

TEST(ShmSlots_test, RandomAllocationsAndFreesNeverOverlap) {
    ShmSlots slots(8 * slot_mib);
    std::mt19937 random(3);
    std::vector<std::pair<std::size_t, std::size_t>> held;  // offset, length
    for (int step = 0; step < 20000; ++step) {
        if (!held.empty() && random() % 2 == 0) {
            const auto i = random() % held.size();
            ASSERT_TRUE(slots.free(held[i].first));
            held.erase(held.begin() + static_cast<std::ptrdiff_t>(i));
            continue;
        }
        const std::size_t length = 1 + random() % (2 * slot_mib);
        const auto offset = slots.allocate(length);
        if (!offset)
            continue;
        ASSERT_LE(*offset + length, 8 * slot_mib);
        for (const auto& [other, other_length] : held)
            ASSERT_TRUE(*offset + length <= other || other + other_length <= *offset)
                << "overlap at step " << step;
        held.emplace_back(*offset, length);
    }
}

}  // namespace
}  // namespace plexus::detail
