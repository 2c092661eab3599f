// The recycled buffers of large received blobs (blob_pool.hpp): a buffer handed back is the one a
// later blob of a size it fits is received into; small, far too large and surplus buffers are not
// kept. The pool is one per process: each test uses sizes of its own so that what another test
// left behind is never the best fit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "../../../client/src/blob_pool.hpp"
#include "plexus/client.hpp"

namespace plexus::detail {
namespace {

constexpr std::size_t mib = 1024 * 1024;

std::vector<std::uint8_t> buffer_of(std::size_t capacity) {
    std::vector<std::uint8_t> bytes;
    bytes.reserve(capacity);
    bytes.assign(100, 7);  // some content: a recycled buffer must come back empty
    return bytes;
}

TEST(BlobPool_test, ABufferHandedBackIsTakenForTheNextBlobItFits) {
    auto bytes = buffer_of(5 * mib + 123);
    const std::uint8_t* memory = bytes.data();
    recycle_blob(std::move(bytes));
    const auto taken = take_blob_buffer(5 * mib);
    EXPECT_EQ(taken.data(), memory) << "a fresh buffer instead of the recycled one";
    EXPECT_TRUE(taken.empty());
    EXPECT_GE(taken.capacity(), 5 * mib);
}

TEST(BlobPool_test, ABufferTooSmallOrFarTooLargeIsNotTaken) {
    auto small = buffer_of(7 * mib);
    const std::uint8_t* small_memory = small.data();
    keep_blob_buffer(std::move(small));
    const auto larger_blob = take_blob_buffer(7 * mib + 1);
    EXPECT_NE(larger_blob.data(), small_memory) << "a buffer smaller than the blob was handed out";
    EXPECT_GE(larger_blob.capacity(), 7 * mib + 1);
    const auto much_smaller_blob = take_blob_buffer(mib + 17);  // 7 MiB is more than 4x too large
    EXPECT_NE(much_smaller_blob.data(), small_memory);
    EXPECT_EQ(take_blob_buffer(7 * mib).data(), small_memory) << "the buffer was not kept";
}

TEST(BlobPool_test, BuffersUnderALargePayloadAreNotKept) {
    std::vector<std::uint8_t> tiny(1000, 1);
    keep_blob_buffer(std::move(tiny));
    EXPECT_EQ(tiny.size(), 1000u) << "a buffer not kept stays with its owner, to be freed as usual";
}

// Buffers are told apart by their capacities (each its own, a fresh one exactly the size asked
// for), not their addresses: the memory of a buffer dropped and freed may well be where malloc
// puts the next fresh one.
std::size_t count_recycled(const std::vector<std::vector<std::uint8_t>>& taken,
                           const std::vector<std::size_t>& handed_back, std::size_t oldest_kept) {
    std::size_t recycled = 0;
    for (const auto& bytes : taken) {
        const auto at = std::find(handed_back.begin(), handed_back.end(), bytes.capacity());
        if (at == handed_back.end())
            continue;
        ++recycled;
        EXPECT_GE(static_cast<std::size_t>(at - handed_back.begin()), oldest_kept)
            << "an old buffer was kept over a newer one";
    }
    return recycled;
}

TEST(BlobPool_test, AtMostEightBuffersAreKeptTheNewest) {
    std::vector<std::size_t> handed_back;
    for (std::size_t i = 0; i < 10; ++i) {
        auto bytes = buffer_of(3 * mib + 1000 + i);  // never the capacity of a fresh one
        handed_back.push_back(bytes.capacity());
        keep_blob_buffer(std::move(bytes));
    }
    std::vector<std::vector<std::uint8_t>> taken;  // held, so each take is a different buffer
    for (std::size_t i = 0; i < 10; ++i)
        taken.push_back(take_blob_buffer(3 * mib));
    EXPECT_EQ(count_recycled(taken, handed_back, 2), 8u);
}

TEST(BlobPool_test, AtMost64MiBAreKept) {
    std::vector<std::size_t> handed_back;
    for (std::size_t i = 0; i < 3; ++i) {
        auto bytes = buffer_of(30 * mib + 1 + i);  // never the capacity of a fresh one
        handed_back.push_back(bytes.capacity());
        keep_blob_buffer(std::move(bytes));
    }
    std::vector<std::vector<std::uint8_t>> taken;
    for (std::size_t i = 0; i < 3; ++i)
        taken.push_back(take_blob_buffer(30 * mib));
    EXPECT_EQ(count_recycled(taken, handed_back, 1), 2u) << "three buffers of 30 MiB: two fit under 64 MiB";
}

}  // namespace
}  // namespace plexus::detail
