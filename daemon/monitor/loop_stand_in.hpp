#pragma once
// Threading: take_over() and give_back() are called on the thread that runs the daemon's event
// loop, from inside one of its handlers; stepped_in() on whichever thread runs the loop. Its own
// thread runs the loop only between a take_over() and the give_back() that follows.
//
// Cheap monitors run inline, on the daemon's thread (monitor/stage.hpp): a message costs no hop to a
// worker and back. A script may still run long -- its budget is 20 ms, and whether it will is
// known only once it does. When an inline script overruns its slice, the sandbox's budget check
// calls take_over(): this thread starts running the event loop's handlers, so the I/O, the control
// plane, the other connections and the signals go on, while the daemon's thread finishes the
// script. Then give_back() waits until this thread is between two handlers and has stopped; the
// daemon's thread carries on from where it was. The daemon's objects are still touched by one
// thread at a time: the handover is made under a mutex, at a point where the thread handing over
// touches nothing of the daemon's until it has the loop back.

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

#include <boost/asio/io_context.hpp>

namespace plexus::daemon::monitor {

class LoopStandIn {
public:
    explicit LoopStandIn(boost::asio::io_context& loop);
    ~LoopStandIn();
    LoopStandIn(const LoopStandIn&) = delete;
    LoopStandIn& operator=(const LoopStandIn&) = delete;

    /// From now on the stand-in runs the loop's handlers; the caller touches nothing of the
    /// daemon's until give_back() returns.
    void take_over();
    /// Returns once the stand-in has stopped between two handlers: the loop is the caller's again.
    void give_back();
    /// True between take_over() and give_back(): the thread running the loop now is the stand-in,
    /// which must not hand over in turn (stages run their monitors on workers meanwhile).
    bool stepped_in() const { return stepped_in_.load(std::memory_order_acquire); }
    /// How many times it took over, for `plexus stats`.
    std::uint64_t takeovers() const { return takeovers_.load(std::memory_order_relaxed); }

    /// What the daemon does around a hand-over when the loop's thread holds more than the loop
    /// (`--threads`: the data threads' gates, net/handler_gate.hpp). Set before the first take_over().
    struct HandOver {
        std::function<void()> lend;  ///< take_over(), on the loop's thread: let go of what it holds
        std::function<void()> lent;  ///< on the stand-in, before it runs the loop: act as the loop's thread
        std::function<void()> returned;  ///< on the stand-in, after it stopped: no longer
        std::function<void()> reclaim;   ///< give_back(), on the loop's thread: take it again
    };
    void set_hand_over(HandOver hand_over) { hand_over_ = std::move(hand_over); }

private:
    void run();

    boost::asio::io_context& loop_;
    HandOver hand_over_;
    std::mutex mutex_;
    std::condition_variable changed_;
    bool running_ = false;                 ///< under mutex_: the stand-in runs the loop
    bool back_wanted_ = false;             ///< under mutex_: give_back() waits
    bool ending_ = false;                  ///< under mutex_
    std::atomic<bool> wants_back_{false};  ///< back_wanted_, for the stand-in's check between handlers
    std::atomic<bool> stepped_in_{false};
    std::atomic<std::uint64_t> takeovers_{0};
    std::thread thread_;  ///< last: starts once the members above are ready
};

}  // namespace plexus::daemon::monitor
