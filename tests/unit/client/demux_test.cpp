// The reply/inbox demultiplexer (demux.hpp): records reach the inbox of their handle in order,
// replies their requester, a closed handle keeps nothing, and a broken connection wakes every
// waiter. Waits are bounded by deadlines and readiness, never by sleeping.
#include <gtest/gtest.h>

#include <future>
#include <thread>

#include "../../../client/src/demux.hpp"

namespace plexus::detail {
namespace {

using namespace std::chrono_literals;

std::shared_ptr<const proto::Bytes> block_of(std::initializer_list<std::uint8_t> bytes) {
    return std::make_shared<const proto::Bytes>(bytes);
}

TEST(Demux_test, RecordsReachTheirHandlesInOrderOneSegmentPerRun) {
    ReadDemand demand;
    Demux demux("test", demand);
    const auto block = block_of({1, 2, 3, 4});
    const std::vector<Delivery> records{{7, {block->data(), 1}},
                                        {7, {block->data() + 1, 1}},
                                        {8, {block->data() + 2, 1}},
                                        {7, {block->data() + 3, 1}}};
    demux.deliver(block, records);

    std::deque<InboxSegment> seven;
    ASSERT_TRUE(demux.take_all(7, 0ms, seven));
    ASSERT_EQ(seven.size(), 2u) << "two runs of handle 7, split by one of 8";
    ASSERT_EQ(seven[0].records.size(), 2u);
    EXPECT_EQ(seven[0].records[0][0], 1);
    EXPECT_EQ(seven[0].records[1][0], 2);
    EXPECT_EQ(seven[1].records[0][0], 4);
    std::deque<InboxSegment> eight;
    ASSERT_TRUE(demux.take_all(8, 0ms, eight));
    EXPECT_EQ(eight.at(0).records.at(0)[0], 3);
    std::deque<InboxSegment> again;
    EXPECT_FALSE(demux.take_all(7, 0ms, again)) << "taken once, gone";
}

TEST(Demux_test, AWaitingReaderIsWokenByADelivery) {
    ReadDemand demand;
    Demux demux("test", demand);
    auto reader = std::async(std::launch::async, [&] {
        std::deque<InboxSegment> into;
        return demux.take_all(3, 10s, into) && into.size() == 1;
    });
    const auto block = block_of({9});
    const std::vector<Delivery> records{{3, {block->data(), 1}}};
    demux.deliver(block, records);  // before or after the reader waits: either way it gets it
    EXPECT_TRUE(reader.get());
}

TEST(Demux_test, AClosedHandleKeepsNothingAndItsWaiterReturns) {
    ReadDemand demand;
    Demux demux("test", demand);
    auto reader = std::async(std::launch::async, [&] {
        std::deque<InboxSegment> into;
        return demux.take_all(5, 10s, into);
    });
    demux.close(5);
    EXPECT_FALSE(reader.get()) << "close() ends the wait of the port's reader";
    EXPECT_FALSE(demux.accepts(5));
    demux.deliver(5, InboxSegment{});
    std::deque<InboxSegment> into;
    EXPECT_FALSE(demux.take_all(5, 0ms, into)) << "records for a closed handle are dropped";
}

TEST(Demux_test, ARepliesReachesItsRequesterAndALateOneIsDropped) {
    ReadDemand demand;
    Demux demux("test", demand);
    const auto first = demux.expect_reply();
    const auto second = demux.expect_reply();
    EXPECT_NE(first, second);
    auto waiter =
        std::async(std::launch::async, [&] { return demux.wait_reply(second, Clock::now() + 10s); });
    demux.deliver_reply(proto::Reply{second, proto::ReplyCode::ok, {{"n", 2}}});
    const auto reply = waiter.get();
    ASSERT_TRUE(reply.has_value());
    EXPECT_EQ(reply->body["n"], 2);
    EXPECT_FALSE(demux.wait_reply(first, Clock::now()).has_value()) << "no reply: a timeout";
    demux.deliver_reply(proto::Reply{first, proto::ReplyCode::ok, {}});  // nobody waits: dropped
    EXPECT_FALSE(demux.wait_reply(first, Clock::now()).has_value());
}

TEST(Demux_test, BreakingWakesEveryWaiterWithTheFirstReason) {
    ReadDemand demand;
    Demux demux("the daemon", demand);
    const auto id = demux.expect_reply();
    auto requester = std::async(std::launch::async, [&] { return demux.wait_reply(id, Clock::now() + 10s); });
    auto reader = std::async(std::launch::async, [&] {
        std::deque<InboxSegment> into;
        return demux.take_all(1, 10s, into);
    });
    demux.fail("first");
    demux.fail("second");
    EXPECT_TRUE(demux.broken());
    try {
        requester.get();
        FAIL() << "a requester of a broken connection got no error";
    } catch (const Error& error) {
        EXPECT_EQ(error.code(), ErrorCode::refused);
        EXPECT_STREQ(error.what(), "connection to the daemon lost: first");
    }
    EXPECT_THROW(reader.get(), Error);
    EXPECT_THROW(demux.throw_if_broken(), Error);
}

TEST(Demux_test, AReaderAsksForReadsUntilItsRecordsCome) {
    // The receiving thread reads only while someone waits (read_demand.hpp): a reader that has
    // what it waited for must stop asking at the delivery, before it even wakes.
    ReadDemand demand;
    Demux demux("test", demand);
    auto reader = std::async(std::launch::async, [&] {
        std::deque<InboxSegment> into;
        return demux.take_all(2, 10s, into);
    });
    const auto until = demand.wait();  // the receiving thread's side: returns once the reader waits
    ASSERT_TRUE(until.has_value());
    EXPECT_GT(*until, Clock::now());
    demux.deliver(2, InboxSegment{});
    EXPECT_TRUE(reader.get());
    demand.stop();
    EXPECT_FALSE(demand.wait().has_value()) << "stop() ends the receiving thread's wait";
}

TEST(Demux_test, RecordsDeliveredBeforeTheBreakAreStillRead) {
    ReadDemand demand;
    Demux demux("test", demand);
    demux.deliver(4, InboxSegment{});
    demux.fail("gone");
    std::deque<InboxSegment> into;
    EXPECT_TRUE(demux.take_all(4, 0ms, into)) << "what came before the end is not lost";
    into.clear();
    EXPECT_THROW(demux.take_all(4, 0ms, into), Error);
}

}  // namespace
}  // namespace plexus::detail
