// The shared-memory rings' byte rings and frames (plexus/proto/rings.hpp), on ordinary memory.
#include "plexus/proto/rings.hpp"

#include <gtest/gtest.h>

#include <numeric>
#include <thread>
#include <vector>

#include "plexus/proto/frame.hpp"

namespace plexus::proto {
namespace {

struct Ring {
    explicit Ring(std::size_t capacity) : bytes(capacity) {
        control.tail = 0;
        control.head = 0;
        control.writer_waiting = 0;
        control.reader_waiting = 0;
        writer = RingWriter(&control, bytes.data(), capacity);
        reader = RingReader(&control, bytes.data(), capacity);
    }
    RingControl control;
    std::vector<std::uint8_t> bytes;
    RingWriter writer;
    RingReader reader;
};

std::size_t write(Ring& ring, const std::vector<std::uint8_t>& data, bool& wake) {
    iovec piece{const_cast<std::uint8_t*>(data.data()), data.size()};
    const auto n = ring.writer.write_some(&piece, 1, wake);
    EXPECT_TRUE(n.has_value());
    return n.value_or(0);
}

TEST(Rings_test, BytesComeOutInOrderAcrossTheWrap) {
    Ring ring(64);
    std::uint8_t next = 0;
    std::uint8_t expected = 0;
    bool wake = false;
    for (int round = 0; round < 200; ++round) {
        std::vector<std::uint8_t> data(static_cast<std::size_t>(round % 37 + 1));
        for (auto& b : data)
            b = next++;
        ASSERT_EQ(write(ring, data, wake), data.size());
        std::vector<std::uint8_t> out(64);
        const auto n = ring.reader.read_some(out.data(), out.size(), wake);
        ASSERT_TRUE(n.has_value());
        ASSERT_EQ(*n, data.size());
        for (std::size_t i = 0; i < *n; ++i)
            ASSERT_EQ(out[i], expected++);
    }
}

TEST(Rings_test, AFullRingTakesWhatFitsAndSaysWhenThereIsNoRoom) {
    Ring ring(64);
    bool wake = false;
    EXPECT_EQ(write(ring, std::vector<std::uint8_t>(100, 7), wake), 64u);
    EXPECT_EQ(write(ring, std::vector<std::uint8_t>(1, 7), wake), 0u);
    EXPECT_EQ(ring.writer.room(), std::optional<std::size_t>(0));
    std::vector<std::uint8_t> out(10);
    EXPECT_EQ(ring.reader.read_some(out.data(), out.size(), wake), std::optional<std::size_t>(10));
    EXPECT_EQ(ring.writer.room(), std::optional<std::size_t>(10));
}

TEST(Rings_test, GatheredPiecesAreWrittenInOrder) {
    Ring ring(64);
    std::vector<std::uint8_t> a{1, 2, 3}, b{4, 5}, c{6};
    iovec pieces[3] = {{a.data(), a.size()}, {b.data(), b.size()}, {c.data(), c.size()}};
    bool wake = false;
    EXPECT_EQ(ring.writer.write_some(pieces, 3, wake), std::optional<std::size_t>(6));
    std::vector<std::uint8_t> out(6);
    ASSERT_EQ(ring.reader.read_some(out.data(), out.size(), wake), std::optional<std::size_t>(6));
    EXPECT_EQ(out, (std::vector<std::uint8_t>{1, 2, 3, 4, 5, 6}));
}

TEST(Rings_test, ASleepingReaderIsWokenOnceAndAnAwakeOneNever) {
    Ring ring(64);
    bool wake = true;
    write(ring, {1}, wake);
    EXPECT_FALSE(wake);  // nobody sleeps: no system call for the writer
    std::vector<std::uint8_t> out(8);
    ring.reader.read_some(out.data(), out.size(), wake);
    EXPECT_FALSE(ring.reader.prepare_to_wait());  // empty: it may sleep, and said so
    write(ring, {2}, wake);
    EXPECT_TRUE(wake);
    write(ring, {3}, wake);
    EXPECT_FALSE(wake);                          // the flag was taken by the first wake-up
    EXPECT_TRUE(ring.reader.prepare_to_wait());  // bytes are there: do not sleep
}

TEST(Rings_test, AWaitingWriterIsWokenWhenRoomIsMade) {
    Ring ring(64);
    bool wake = false;
    write(ring, std::vector<std::uint8_t>(64, 1), wake);
    EXPECT_FALSE(ring.writer.prepare_to_wait());
    std::vector<std::uint8_t> out(8);
    ring.reader.read_some(out.data(), out.size(), wake);
    EXPECT_TRUE(wake);
}

TEST(Rings_test, ImpossiblePositionsAreReportedNotTrusted) {
    Ring ring(64);
    bool wake = false;
    // A producer claiming more than the ring holds.
    ring.control.tail = 65;
    std::vector<std::uint8_t> out(8);
    EXPECT_FALSE(ring.reader.read_some(out.data(), out.size(), wake).has_value());
    EXPECT_FALSE(ring.reader.available().has_value());
    EXPECT_TRUE(ring.reader.prepare_to_wait());  // never sleeps on a lie: it reports it
    // A consumer claiming to have read what was never written.
    Ring other(64);
    other.control.head = 5;
    EXPECT_FALSE(other.writer.room().has_value());
    std::uint8_t byte = 1;
    iovec piece{&byte, 1};
    EXPECT_FALSE(other.writer.write_some(&piece, 1, wake).has_value());
}

TEST(Rings_test, AWriterAndAReaderOnTwoThreadsPassEveryByteInOrder) {
    // The two ends as the two processes use them, here two threads (ThreadSanitizer checks that
    // the positions' release and acquire order the copies of the bytes): a small ring, wrapped
    // many times, pieces of changing sizes, each side yielding when it can do nothing.
    Ring ring(256);
    constexpr std::size_t total = 1 << 20;
    std::thread writer([&] {
        std::vector<std::uint8_t> piece(97);
        std::size_t sent = 0;
        while (sent < total) {
            const std::size_t size = std::min(piece.size() - sent % 13, total - sent);
            for (std::size_t i = 0; i < size; ++i)
                piece[i] = static_cast<std::uint8_t>((sent + i) * 7);
            iovec at{piece.data(), size};
            bool wake = false;
            const auto n = ring.writer.write_some(&at, 1, wake);
            ASSERT_TRUE(n.has_value());
            sent += *n;
            if (*n == 0)
                std::this_thread::yield();
        }
    });
    std::vector<std::uint8_t> out(61);
    std::size_t received = 0;
    while (received < total) {
        bool wake = false;
        const auto n = ring.reader.read_some(out.data(), out.size(), wake);
        ASSERT_TRUE(n.has_value());
        for (std::size_t i = 0; i < *n; ++i)
            ASSERT_EQ(out[i], static_cast<std::uint8_t>((received + i) * 7)) << "byte " << received + i;
        received += *n;
        if (*n == 0)
            std::this_thread::yield();
    }
    writer.join();
    EXPECT_EQ(ring.reader.available(), std::optional<std::size_t>(0));
}

TEST(Rings_test, FramesRoundTrip) {
    const auto request = make_rings_request(1 << 20);
    auto decoded = FrameDecoder().decode(request);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    EXPECT_EQ(decoded.type, FrameType::rings);
    EXPECT_EQ(decode_rings_request(decoded.fields).value(), 1u << 20);
    const auto answer = make_rings_answer({0, "shared-memory rings are off"});
    decoded = FrameDecoder().decode(answer);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    const auto back = decode_rings_answer(decoded.fields);
    ASSERT_TRUE(back.ok());
    EXPECT_EQ(back->ring_bytes, 0u);
    EXPECT_EQ(back->reason, "shared-memory rings are off");
    EXPECT_FALSE(decode_rings_request(Bytes{0x01, 0x02}).ok());  // bytes after the size
    EXPECT_FALSE(decode_rings_answer(Bytes{0x80}).ok());         // a cut varint
}

TEST(Rings_test, RingSizesAreBoundedPowersOfTwo) {
    EXPECT_EQ(RingLayout::ring_bytes_for(0), RingLayout::default_ring_bytes);
    EXPECT_EQ(RingLayout::ring_bytes_for(1), RingLayout::min_ring_bytes);
    EXPECT_EQ(RingLayout::ring_bytes_for(100'000), 131072u);
    EXPECT_EQ(RingLayout::ring_bytes_for(~std::uint64_t{0}), RingLayout::max_ring_bytes);
}

}  // namespace
}  // namespace plexus::proto
