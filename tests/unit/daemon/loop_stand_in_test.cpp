// The LoopStandIn (daemon/monitor/loop_stand_in.hpp): while a handler of the daemon's loop is busy
// in a script that overran, another thread runs the loop's other handlers; then the loop is given
// back and the busy handler's thread carries on. The daemon's io_context has a concurrency hint
// of 1, as here.
#include "monitor/loop_stand_in.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <thread>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/post.hpp>

namespace plexus::daemon::monitor {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

/// Polls `done` until it holds or 10 s pass (no sleeping: the other thread makes it true).
template <typename Predicate>
bool poll_until(Predicate done) {
    const auto deadline = Clock::now() + 10s;
    while (!done()) {
        if (Clock::now() > deadline)
            return false;
        std::this_thread::yield();
    }
    return true;
}

TEST(LoopStandIn_test, RunsTheLoopWhileAHandlerIsBusyThenGivesItBack) {
    boost::asio::io_context io(1);
    auto work = boost::asio::make_work_guard(io);
    LoopStandIn stand_in(io);
    const auto main_thread = std::this_thread::get_id();
    std::atomic<bool> other_ran{false};
    std::thread::id other_thread;
    std::thread::id after_thread;
    bool was_stepped_in = false;
    boost::asio::post(io, [&] {
        stand_in.take_over();
        // A handler posted while this one is busy (as a session's read would complete).
        std::thread([&] {
            boost::asio::post(io, [&] {
                other_thread = std::this_thread::get_id();
                was_stepped_in = stand_in.stepped_in();
                other_ran = true;
            });
        }).join();
        EXPECT_TRUE(poll_until([&] { return other_ran.load(); })) << "the stand-in ran nothing";
        stand_in.give_back();
        EXPECT_FALSE(stand_in.stepped_in());
        boost::asio::post(io, [&] {
            after_thread = std::this_thread::get_id();
            work.reset();
        });
    });
    io.run();
    EXPECT_TRUE(other_ran);
    EXPECT_NE(other_thread, main_thread);
    EXPECT_TRUE(was_stepped_in);
    EXPECT_EQ(after_thread, main_thread) << "the loop was not given back";
    EXPECT_EQ(stand_in.takeovers(), 1u);
}

TEST(LoopStandIn_test, GivingBackAtOnceNeverHangs) {
    // give_back() may come before the stand-in's thread has even woken for take_over().
    boost::asio::io_context io(1);
    auto work = boost::asio::make_work_guard(io);
    LoopStandIn stand_in(io);
    int rounds = 0;
    // One round at a time, each posted by the one before once it has the loop back: a handler
    // waiting in the queue during a round would be run by the stand-in, which must not hand over
    // in turn (stages check stepped_in() for that).
    std::function<void()> round = [&] {
        stand_in.take_over();
        stand_in.give_back();
        if (++rounds < 2000)
            boost::asio::post(io, round);
        else
            work.reset();
    };
    boost::asio::post(io, round);
    io.run();
    EXPECT_EQ(rounds, 2000);
    EXPECT_EQ(stand_in.takeovers(), 2000u);
}

TEST(LoopStandIn_test, ALoopStoppedWhileSteppedInEndsOnceGivenBack) {
    // SIGTERM handled by the stand-in stops the loop; the busy handler ends, and run() returns.
    boost::asio::io_context io(1);
    auto work = boost::asio::make_work_guard(io);
    LoopStandIn stand_in(io);
    boost::asio::post(io, [&] {
        stand_in.take_over();
        std::thread([&] { boost::asio::post(io, [&] { io.stop(); }); }).join();
        EXPECT_TRUE(poll_until([&] { return io.stopped(); }));
        stand_in.give_back();
    });
    io.run();  // returns: the loop is stopped, and given back
    EXPECT_TRUE(io.stopped());
}

}  // namespace
}  // namespace plexus::daemon::monitor
