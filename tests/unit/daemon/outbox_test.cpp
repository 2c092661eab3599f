#include "net/outbox.hpp"

#include <gtest/gtest.h>

#include "plexus/proto/frame.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::daemon {
namespace {

/// A message whose record is `size` bytes of `fill`, in a chunk of its own.
Message record_of(std::size_t size, std::uint8_t fill, std::uint64_t seq) {
    auto chunk = std::make_shared<Chunk>(size);
    std::fill(chunk->data(), chunk->data() + size, fill);
    proto::ByteView record{chunk->data(), size};
    return Message{std::move(chunk), record, seq};
}

/// Everything the batch would write, in order.
proto::Bytes written(const Batch& batch) {
    proto::Bytes out;
    for (const auto& buffer : batch.buffers) {
        const auto* bytes = static_cast<const std::uint8_t*>(buffer.data());
        out.insert(out.end(), bytes, bytes + buffer.size());
    }
    return out;
}

struct DecodedFrame {
    proto::FrameType type;
    std::uint64_t handle = 0;
    proto::Bytes record;
};

std::vector<DecodedFrame> frames_in(const proto::Bytes& stream) {
    std::vector<DecodedFrame> frames;
    const proto::FrameDecoder decoder;
    std::size_t at = 0;
    while (at < stream.size()) {
        auto decoded = decoder.decode({stream.data() + at, stream.size() - at});
        EXPECT_EQ(decoded.status, proto::DecodeStatus::frame);
        if (decoded.status != proto::DecodeStatus::frame)
            break;
        DecodedFrame frame{decoded.type, 0, {}};
        if (decoded.type == proto::FrameType::data) {
            auto data = proto::decode_data(decoded.fields);
            frame.handle = data->handle;
            frame.record.assign(data->record.begin(), data->record.end());
        } else {
            frame.record.assign(decoded.fields.begin(), decoded.fields.end());
        }
        frames.push_back(std::move(frame));
        at += decoded.used;
    }
    return frames;
}

TEST(Outbox_test, ControlFramesLeaveFirstThenDataFramesRoundRobin) {
    ReaderQueue first(QueuePolicy::strict, 10);
    ReaderQueue second(QueuePolicy::strict, 10);
    first.push(record_of(3, 0xa1, 1));
    first.push(record_of(3, 0xa2, 2));
    second.push(record_of(5, 0xb1, 1));
    Outbox outbox(nullptr);
    outbox.add_source({7, &first, nullptr, nullptr});
    outbox.add_source({9, &second, nullptr, nullptr});
    outbox.push_control(proto::make_error_frame("x"));
    Batch batch;
    outbox.fill(batch, 1 << 20);
    auto frames = frames_in(written(batch));
    ASSERT_EQ(frames.size(), 4u);
    EXPECT_EQ(frames[0].type, proto::FrameType::error);
    EXPECT_EQ(frames[1].handle, 7u);
    EXPECT_EQ(frames[1].record, proto::Bytes(3, 0xa1));
    EXPECT_EQ(frames[2].handle, 9u);
    EXPECT_EQ(frames[2].record, proto::Bytes(5, 0xb1));
    EXPECT_EQ(frames[3].handle, 7u);
    EXPECT_EQ(frames[3].record, proto::Bytes(3, 0xa2));
    EXPECT_TRUE(outbox.empty());
}

TEST(Outbox_test, SmallRecordsAreCopiedIntoFewBuffersAndReleaseTheirChunks) {
    ReaderQueue queue(QueuePolicy::strict, 5000);
    std::weak_ptr<const Chunk> first_chunk;
    for (std::uint64_t i = 0; i < 2000; ++i) {
        auto message = record_of(64, static_cast<std::uint8_t>(i), i);
        if (i == 0)
            first_chunk = message.storage;
        queue.push(message);
    }
    Outbox outbox(nullptr);
    std::uint64_t sent = 0;
    outbox.add_source({1, &queue, &sent, nullptr});
    Batch batch;
    outbox.fill(batch, 1 << 20);
    EXPECT_EQ(sent, 2000u);
    EXPECT_EQ(batch.buffers.size(), 1u);  // one contiguous buffer, not two per message
    EXPECT_TRUE(batch.messages.empty());
    EXPECT_TRUE(first_chunk.expired());  // copied: nothing keeps the read chunk alive
    auto frames = frames_in(written(batch));
    ASSERT_EQ(frames.size(), 2000u);
    for (std::size_t i = 0; i < frames.size(); ++i)
        EXPECT_EQ(frames[i].record, proto::Bytes(64, static_cast<std::uint8_t>(i))) << "frame " << i;
}

TEST(Outbox_test, LargeRecordsAreSentFromTheirChunkWithoutACopy) {
    ReaderQueue queue(QueuePolicy::strict, 10);
    const auto large = record_of(100000, 0x42, 1);
    queue.push(record_of(10, 0x01, 1));
    queue.push(large);
    queue.push(record_of(10, 0x02, 2));
    Outbox outbox(nullptr);
    outbox.add_source({3, &queue, nullptr, nullptr});
    Batch batch;
    outbox.fill(batch, 1 << 20);
    ASSERT_EQ(batch.messages.size(), 1u);
    bool referenced = false;
    for (const auto& buffer : batch.buffers)
        referenced = referenced || buffer.data() == large.record.data();
    EXPECT_TRUE(referenced);
    auto frames = frames_in(written(batch));
    ASSERT_EQ(frames.size(), 3u);
    EXPECT_EQ(frames[0].record, proto::Bytes(10, 0x01));
    EXPECT_EQ(frames[1].record, proto::Bytes(100000, 0x42));
    EXPECT_EQ(frames[2].record, proto::Bytes(10, 0x02));
}

TEST(Outbox_test, StopsNearTheBudgetAndCallsOnSpaceWhenAStrictQueueDropsBelowFull) {
    ReaderQueue queue(QueuePolicy::strict, 100);
    for (std::uint64_t i = 0; i < 100; ++i)
        queue.push(record_of(1000, 0x11, i));
    int space_calls = 0;
    Outbox outbox([&] { ++space_calls; });
    outbox.add_source({1, &queue, nullptr, nullptr});
    Batch batch;
    outbox.fill(batch, 10000);
    EXPECT_GE(batch.bytes, 10000u);
    EXPECT_LT(batch.bytes, 10000u + 1100u);
    EXPECT_EQ(space_calls, 1);
    EXPECT_FALSE(outbox.empty());
    EXPECT_EQ(frames_in(written(batch)).size(), 100u - queue.depth());
}

TEST(Outbox_test, HigherPrioritySourcesAreServedFirstAndEqualOnesTakeTurns) {
    ReaderQueue low(QueuePolicy::strict, 10);
    ReaderQueue high_a(QueuePolicy::strict, 10);
    ReaderQueue high_b(QueuePolicy::strict, 10);
    for (std::uint8_t i = 0; i < 3; ++i)
        low.push(record_of(3, static_cast<std::uint8_t>(0x10 + i), i));
    for (std::uint8_t i = 0; i < 2; ++i) {
        high_a.push(record_of(3, static_cast<std::uint8_t>(0xa0 + i), i));
        high_b.push(record_of(3, static_cast<std::uint8_t>(0xb0 + i), i));
    }
    int high_priority = 5;
    Outbox outbox(nullptr);
    // The low source comes first in the round-robin order: only its priority puts it last.
    outbox.add_source({1, &low, nullptr, nullptr, [] { return 0; }});
    outbox.add_source({2, &high_a, nullptr, nullptr, [&] { return high_priority; }});
    outbox.add_source({3, &high_b, nullptr, nullptr, [&] { return high_priority; }});
    Batch batch;
    outbox.fill(batch, 1 << 20);
    auto frames = frames_in(written(batch));
    ASSERT_EQ(frames.size(), 7u);
    const std::vector<std::uint64_t> handles{2, 3, 2, 3, 1, 1, 1};
    for (std::size_t i = 0; i < frames.size(); ++i)
        EXPECT_EQ(frames[i].handle, handles[i]) << "frame " << i;
    EXPECT_EQ(frames[0].record, proto::Bytes(3, 0xa0));
    EXPECT_EQ(frames[4].record, proto::Bytes(3, 0x10));

    // A one-frame budget: each batch takes the highest source that has messages, read anew.
    low.push(record_of(3, 0x20, 9));
    high_a.push(record_of(3, 0xa9, 9));
    high_priority = 0;  // now below nothing: equal to low, so they take turns
    batch.clear();
    outbox.fill(batch, 1);
    frames = frames_in(written(batch));
    ASSERT_EQ(frames.size(), 1u);
    batch.clear();
    outbox.fill(batch, 1);
    const auto second = frames_in(written(batch));
    ASSERT_EQ(second.size(), 1u);
    EXPECT_NE(frames[0].handle, second[0].handle) << "equal priorities take turns";
}

TEST(Outbox_test, ALowerSourceIsServedOnceTheHigherOnesAreEmpty) {
    ReaderQueue low(QueuePolicy::strict, 10);
    ReaderQueue high(QueuePolicy::strict, 10);
    low.push(record_of(3, 0x01, 1));
    high.push(record_of(3, 0x02, 1));
    Outbox outbox(nullptr);
    outbox.add_source({1, &low, nullptr, nullptr});  // no priority: 0
    outbox.add_source({2, &high, nullptr, nullptr, [] { return 7; }});
    Batch batch;
    outbox.fill(batch, 1);
    auto frames = frames_in(written(batch));
    ASSERT_EQ(frames.size(), 1u);
    EXPECT_EQ(frames[0].handle, 2u);
    batch.clear();
    outbox.fill(batch, 1);
    frames = frames_in(written(batch));
    ASSERT_EQ(frames.size(), 1u);
    EXPECT_EQ(frames[0].handle, 1u);
    EXPECT_TRUE(outbox.empty());
}

}  // namespace
}  // namespace plexus::daemon
