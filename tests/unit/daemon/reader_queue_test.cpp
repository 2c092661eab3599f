#include "core/reader_queue.hpp"

#include "test_messages.hpp"

#include <gtest/gtest.h>

namespace plexus::daemon {
namespace {

Message numbered(std::uint64_t seq) {
    return Message{nullptr, {}, seq};
}

TEST(ReaderQueue_test, StrictQueueReportsFullAtCapacityAndNeverDrops) {
    ReaderQueue queue(QueuePolicy::strict, 3);
    for (std::uint64_t i = 1; i <= 3; ++i)
        queue.push(numbered(i));
    EXPECT_TRUE(queue.full());
    queue.push(numbered(4));  // past the bound, still kept: nothing promised is lost
    EXPECT_EQ(queue.depth(), 4u);
    EXPECT_EQ(queue.dropped(), 0u);
    for (std::uint64_t i = 1; i <= 4; ++i)
        EXPECT_EQ(queue.pop().seq, i);
}

TEST(ReaderQueue_test, LatestQueueKeepsTheNewestAndCountsDrops) {
    ReaderQueue queue(QueuePolicy::latest, 2);
    for (std::uint64_t i = 1; i <= 5; ++i)
        queue.push(numbered(i));
    EXPECT_FALSE(queue.full());
    EXPECT_EQ(queue.depth(), 2u);
    EXPECT_EQ(queue.dropped(), 3u);
    EXPECT_EQ(queue.pushed(), 5u);
    EXPECT_EQ(queue.pop().seq, 4u);
    EXPECT_EQ(queue.pop().seq, 5u);
    EXPECT_TRUE(queue.empty());
}

TEST(ReaderQueue_test, PolicyNamesParseBothWays) {
    EXPECT_EQ(parse_queue_policy("strict"), QueuePolicy::strict);
    EXPECT_EQ(parse_queue_policy("latest"), QueuePolicy::latest);
    EXPECT_FALSE(parse_queue_policy("lossy").has_value());
    EXPECT_EQ(queue_policy_name(QueuePolicy::latest), "latest");
}

}  // namespace
}  // namespace plexus::daemon

namespace plexus::daemon {
namespace {

Message sized(std::uint64_t seq, const std::shared_ptr<Chunk>& chunk, std::size_t size) {
    return Message{chunk, {chunk->data(), size}, seq};
}

TEST(ReaderQueue_test, AStrictQueueIsAlsoFullWhenItHoldsItsByteBound) {
    auto chunk = std::make_shared<Chunk>(1000);
    ReaderQueue queue(QueuePolicy::strict, 100, 2500);
    queue.push(sized(1, chunk, 1000));
    queue.push(sized(2, chunk, 1000));
    EXPECT_FALSE(queue.full());
    queue.push(sized(3, chunk, 1000));
    EXPECT_TRUE(queue.full());
    queue.pop();
    EXPECT_FALSE(queue.full());
    EXPECT_EQ(queue.bytes(), 2000u);
}

TEST(ReaderQueue_test, ALatestQueueDropsOldestToStayWithinItsByteBoundButKeepsTheNewest) {
    auto chunk = std::make_shared<Chunk>(1000);
    ReaderQueue queue(QueuePolicy::latest, 100, 2500);
    for (std::uint64_t i = 1; i <= 4; ++i)
        queue.push(sized(i, chunk, 1000));
    EXPECT_EQ(queue.depth(), 2u);
    EXPECT_EQ(queue.dropped(), 2u);
    ReaderQueue tiny(QueuePolicy::latest, 100, 10);
    tiny.push(sized(1, chunk, 1000));
    EXPECT_EQ(tiny.depth(), 1u) << "a message larger than the bound on its own is still delivered";
}

using test::seqs_of;

/// A batch of `n` records from /w, each with a `size`-byte payload.
Message batch_of(std::uint32_t n, std::size_t size = 10) {
    return test::batch_of(
        n, "/w", [size](std::uint32_t seq) { return proto::Bytes(size, static_cast<std::uint8_t>(seq)); });
}

TEST(ReaderQueue_test, AStrictQueueKeepsABatchWholeAndCountsItsRecords) {
    ReaderQueue queue(QueuePolicy::strict, 8);
    queue.push(batch_of(5));
    EXPECT_EQ(queue.depth(), 5u);
    EXPECT_EQ(queue.room(), 3u);
    EXPECT_EQ(queue.pushed(), 5u);
    queue.push(batch_of(3));
    EXPECT_TRUE(queue.full());
    EXPECT_EQ(queue.room(), 0u);
    const Message first = queue.pop();
    EXPECT_EQ(first.batch, 5u);
    EXPECT_EQ(seqs_of(first), (std::vector<std::uint64_t>{1, 2, 3, 4, 5}));
    EXPECT_EQ(queue.depth(), 3u);
}

TEST(ReaderQueue_test, ALatestQueueSplitsABatchAndDropsSingleMessages) {
    ReaderQueue queue(QueuePolicy::latest, 3);
    queue.push(batch_of(5));
    EXPECT_EQ(queue.depth(), 3u);
    EXPECT_EQ(queue.dropped(), 2u);
    std::vector<std::uint64_t> kept;
    while (!queue.empty()) {
        const Message single = queue.pop();
        EXPECT_EQ(single.batch, 0u);
        kept.push_back(proto::decode_record(single.record)->seq);
    }
    EXPECT_EQ(kept, (std::vector<std::uint64_t>{3, 4, 5}));
}

TEST(ReaderQueue_test, ABatchCutsIntoAHeadAndARestThatTogetherHoldEveryRecord) {
    const Message batch = batch_of(6, 100);
    const Message head = first_records(batch, 2);
    const Message rest = without_first_records(batch, 2);
    EXPECT_EQ(head.batch, 2u);
    EXPECT_EQ(rest.batch, 4u);
    EXPECT_EQ(seqs_of(head), (std::vector<std::uint64_t>{1, 2}));
    EXPECT_EQ(seqs_of(rest), (std::vector<std::uint64_t>{3, 4, 5, 6}));
    EXPECT_EQ(head.record.size() + rest.record.size(), batch.record.size());
}

}  // namespace
}  // namespace plexus::daemon
