// The calls of one connection (call_book.hpp): each call ends once, a lost connection ends them all,
// calls to a served port are taken in order and a stop wakes the taker.
#include "../../../client/src/call_book.hpp"

#include <gtest/gtest.h>

#include <thread>

namespace plexus::detail {
namespace {

using std::chrono::milliseconds;

TEST(CallBook_test, EachCallEndsOnceWithItsAnswer) {
    ReadDemand demand;
    CallBook book(demand);
    std::vector<CallAnswer> ended;
    const auto first = book.add([&](CallAnswer a) { ended.push_back(std::move(a)); },
                                CallBook::Clock::now() + milliseconds(100));
    const auto second = book.add([&](CallAnswer a) { ended.push_back(std::move(a)); },
                                 CallBook::Clock::now() + milliseconds(100));
    ASSERT_NE(first, second);
    EXPECT_EQ(book.waiting(), 2u);
    EXPECT_TRUE(book.complete(second, CallAnswer{proto::CallOutcome::ok, {1, 2}, ""}));
    EXPECT_FALSE(book.complete(second, CallAnswer{proto::CallOutcome::ok, {}, ""})) << "answered twice";
    book.fail(first, proto::CallOutcome::lost, "gone");
    ASSERT_EQ(ended.size(), 2u);
    EXPECT_EQ(ended[0].record, (proto::Bytes{1, 2}));
    EXPECT_EQ(ended[1].outcome, proto::CallOutcome::lost);
    EXPECT_EQ(ended[1].reason, "gone");
    EXPECT_EQ(book.waiting(), 0u);
}

TEST(CallBook_test, ALostConnectionEndsEveryCallAndRefusesNewOnes) {
    ReadDemand demand;
    CallBook book(demand);
    int lost = 0;
    for (int i = 0; i < 5; ++i)
        book.add([&](CallAnswer a) { lost += a.outcome == proto::CallOutcome::lost; },
                 CallBook::Clock::now());
    book.fail_all("the daemon went away");
    EXPECT_EQ(lost, 5);
    std::string why;
    EXPECT_EQ(book.add([&](CallAnswer a) { why = a.reason; }, CallBook::Clock::now()), 0u);
    EXPECT_EQ(why, "the daemon went away");
}

TEST(CallBook_test, CallsToAServedPortAreTakenInOrderAndAStopWakesTheTaker) {
    ReadDemand demand;
    CallBook book(demand);
    book.deliver(3, IncomingCall{10, 100, {}});
    book.deliver(3, IncomingCall{11, 100, {}});
    std::deque<IncomingCall> taken;
    ASSERT_TRUE(book.take(3, CallBook::Clock::now(), taken));
    ASSERT_EQ(taken.size(), 2u);
    EXPECT_EQ(taken[0].id, 10u);
    EXPECT_EQ(taken[1].id, 11u);
    taken.clear();
    EXPECT_FALSE(book.take(3, CallBook::Clock::now() + milliseconds(10), taken)) << "nothing more came";

    std::thread stopper([&] { book.stop(3); });
    EXPECT_FALSE(book.take(3, CallBook::Clock::now() + std::chrono::seconds(30), taken));
    stopper.join();
    book.deliver(3, IncomingCall{12, 100, {}});  // kept no more
    EXPECT_FALSE(book.take(3, CallBook::Clock::now(), taken));
}

}  // namespace
}  // namespace plexus::detail
