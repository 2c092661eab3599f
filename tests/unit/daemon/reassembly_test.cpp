#include "core/reassembly.hpp"

#include <gtest/gtest.h>

namespace plexus::daemon {
namespace {

using Clock = DatagramStream::Clock;
using namespace std::chrono_literals;

/// The datagrams of one message of `length` bytes (byte i is i % 251), cut at `fragment_size`.
struct Sent {
    std::vector<proto::Bytes> datagrams;
    std::vector<proto::DatagramView> views;
};
Sent send(std::uint64_t message, std::size_t length, std::size_t fragment_size) {
    Sent sent;
    const auto count = proto::fragment_count(length, fragment_size);
    for (std::uint64_t i = 0; i < count; ++i) {
        proto::Bytes d;
        proto::append_datagram_header(d, {7, message, length, fragment_size, i, false});
        for (std::size_t b = i * fragment_size; b < std::min(length, (i + 1) * fragment_size); ++b)
            d.push_back(static_cast<std::uint8_t>(b % 251));
        sent.datagrams.push_back(std::move(d));
    }
    for (const auto& d : sent.datagrams)
        sent.views.push_back(*proto::decode_datagram(d, 1u << 30));
    return sent;
}

bool intact(const Message& m, std::size_t length) {
    if (m.record.size() != length)
        return false;
    for (std::size_t b = 0; b < length; ++b) {
        if (m.record[b] != b % 251)
            return false;
    }
    return true;
}

class Reassembly_test : public ::testing::Test {
protected:
    std::shared_ptr<ReassemblyBudget> budget = std::make_shared<ReassemblyBudget>();
    DatagramStream stream{budget, {}};
    Clock::time_point now{};
};

TEST_F(Reassembly_test, PutsFragmentsTogetherInAnyOrder) {
    auto sent = send(0, 10000, 1400);
    std::optional<Message> done;
    for (auto i = sent.views.size(); i-- > 0;) {
        EXPECT_FALSE(done);
        done = stream.take(sent.views[i], now);
    }
    ASSERT_TRUE(done);
    EXPECT_TRUE(intact(*done, 10000));
    EXPECT_EQ(stream.counters().messages, 1u);
    EXPECT_EQ(stream.counters().lost, 0u);
    EXPECT_EQ(budget->bytes, 0u);
}

TEST_F(Reassembly_test, CountsEachGapAsLost) {
    for (std::uint64_t m : {0, 1, 4, 5, 9}) {
        auto sent = send(m, 10, 1400);
        EXPECT_TRUE(stream.take(sent.views[0], now));
    }
    EXPECT_EQ(stream.counters().lost, 5u);  // 2, 3, 6, 7, 8
    EXPECT_EQ(stream.counters().messages, 5u);
}

TEST_F(Reassembly_test, AMessageMissingOneFragmentIsLostNeverTorn) {
    auto big = send(0, 1 << 20, 1400);
    for (std::size_t i = 0; i < big.views.size(); ++i) {
        if (i != 300) {
            EXPECT_FALSE(stream.take(big.views[i], now));  // braces: EXPECT_ is an if of its own
        }
    }
    auto next = send(1, 100, 1400);
    auto done = stream.take(next.views[0], now);
    ASSERT_TRUE(done);
    EXPECT_EQ(done->seq, 1u);
    EXPECT_EQ(stream.counters().lost, 1u);
    EXPECT_EQ(stream.counters().incomplete, 1u);
    EXPECT_EQ(budget->bytes, 0u);
    EXPECT_FALSE(stream.take(big.views[300], now));  // the missing piece, too late
    EXPECT_EQ(stream.counters().late, 1u);
}

TEST_F(Reassembly_test, AnUnfinishedMessageTimesOutAsLost) {
    auto big = send(0, 5000, 1000);
    stream.take(big.views[0], now);
    stream.expire(now + 999ms);
    EXPECT_EQ(stream.counters().lost, 0u);
    stream.expire(now + 1s);
    EXPECT_EQ(stream.counters().lost, 1u);
    EXPECT_EQ(budget->bytes, 0u);
}

TEST_F(Reassembly_test, LateAndDuplicateDatagramsAreCountedAndDropped) {
    auto first = send(0, 10, 1400);
    auto second = send(1, 10, 1400);
    EXPECT_TRUE(stream.take(second.views[0], now));
    EXPECT_FALSE(stream.take(first.views[0], now));
    EXPECT_FALSE(stream.take(second.views[0], now));
    EXPECT_EQ(stream.counters().late, 2u);
    EXPECT_EQ(stream.counters().lost, 1u);
    auto big = send(2, 3000, 1000);
    stream.take(big.views[0], now);
    stream.take(big.views[0], now);
    EXPECT_EQ(stream.counters().late, 3u);
}

TEST_F(Reassembly_test, TheBudgetBoundsTheBytesHeld) {
    budget->max_bytes = 10000;
    auto a = send(0, 8000, 1000);
    auto b = send(1, 8000, 1000);
    stream.take(a.views[0], now);
    EXPECT_EQ(budget->bytes, 8000u);
    stream.take(b.views[0], now);  // no room: message 1 lost, and 0 with it to keep the order
    EXPECT_LE(budget->bytes, 10000u);
    EXPECT_EQ(stream.counters().lost, 2u);
    for (std::size_t i = 1; i < b.views.size(); ++i)
        EXPECT_FALSE(stream.take(b.views[i], now));
    EXPECT_EQ(budget->bytes, 0u);
}

TEST_F(Reassembly_test, TooManyUnfinishedMessagesMakeTheOldestGiveWay) {
    std::vector<Sent> sent;
    for (std::uint64_t m = 0; m < 9; ++m) {
        sent.push_back(send(m, 2000, 1000));
        stream.take(sent.back().views[0], now);
    }
    EXPECT_EQ(stream.counters().lost, 1u);  // message 0
    EXPECT_TRUE(stream.take(sent[1].views[1], now));
    EXPECT_LE(stream.held_bytes(), 7u * 2000u);
}

TEST_F(Reassembly_test, AOneDatagramMessageUnderTheNumberOfAnUnfinishedOneLeavesNothingBehind) {
    // Message 0 is begun in fragments; a datagram then says message 0 is one datagram long (a
    // broken or forged sender). Handed on, it used to leave the unfinished message 0 behind the
    // stream's position: never expired, never counted, holding its bytes of the daemon's budget
    // for good, and outside the bound on unfinished messages.
    auto big = send(0, 3000, 1000);
    EXPECT_FALSE(stream.take(big.views[0], now));
    auto single = send(0, 10, 1400);
    EXPECT_FALSE(stream.take(single.views[0], now));
    EXPECT_EQ(stream.counters().late, 1u);
    EXPECT_FALSE(stream.take(big.views[1], now));
    auto done = stream.take(big.views[2], now);
    ASSERT_TRUE(done);
    EXPECT_TRUE(intact(*done, 3000));
    EXPECT_EQ(budget->bytes, 0u);

    // The same when the unfinished one is never finished: it expires and frees its bytes.
    auto other = send(1, 3000, 1000);
    stream.take(other.views[0], now);
    EXPECT_FALSE(stream.take(send(1, 10, 1400).views[0], now));
    stream.expire(now + 1s);
    EXPECT_EQ(stream.counters().lost, 1u);
    EXPECT_EQ(stream.held_bytes(), 0u);
    EXPECT_EQ(budget->bytes, 0u);
}

TEST_F(Reassembly_test, AStreamJoinedMidwayStartsNoEarlierThanTheSendersNextMessage) {
    // A multicast group joined when the sender's next message was 10: an old datagram replayed
    // (9, or 3) does not start the stream, and so is never handed on; 10 does.
    DatagramStream::Limits limits;
    limits.start_anywhere = true;
    limits.first = 10;
    DatagramStream joined(budget, limits);
    EXPECT_FALSE(joined.take(send(9, 10, 1400).views[0], now));
    EXPECT_FALSE(joined.take(send(3, 10, 1400).views[0], now));
    EXPECT_EQ(joined.counters().late, 2u);
    EXPECT_TRUE(joined.take(send(10, 10, 1400).views[0], now));
    EXPECT_FALSE(joined.take(send(9, 10, 1400).views[0], now));
    EXPECT_TRUE(joined.take(send(12, 10, 1400).views[0], now));
    EXPECT_EQ(joined.counters().messages, 2u);
    EXPECT_EQ(joined.counters().lost, 1u);  // 11
}

}  // namespace
}  // namespace plexus::daemon
