#pragma once
// Threading: one io_context thread; notify() and the waits run on it.

#include <chrono>
#include <vector>

#include <boost/asio/any_completion_handler.hpp>

#include "asio.hpp"

namespace plexus::daemon {

/// Wakes every coroutine waiting on it. Waiters re-check their condition in a loop, so a notify with
/// nobody waiting is harmless (single thread: nothing runs between the check and the wait).
///
/// wait() parks the coroutine's completion handler and notify() posts it: no timer, so no timerfd
/// system calls on the per-message path (a steady_timer at time_point::max() cost one or two per
/// wake-up). wait_for() uses a timer, for the rarer waits that need a deadline.
class Signal {
public:
    explicit Signal(asio::any_io_executor executor) : executor_(std::move(executor)) {}
    Signal(const Signal&) = delete;
    Signal& operator=(const Signal&) = delete;

    void notify() {
        auto handlers = std::move(handlers_);
        handlers_.clear();
        for (auto& handler : handlers)
            asio::post(executor_, std::move(handler));
        for (auto* waiter : timed_) {
            waiter->notified = true;
            waiter->timer.cancel();
        }
    }

    Task<void> wait() {
        co_await asio::async_initiate<const asio::use_awaitable_t<>, void()>(
            [this](auto handler) { handlers_.emplace_back(std::move(handler)); }, asio::use_awaitable);
    }

    /// Waits at most `timeout`; true if notified, false on timeout.
    Task<bool> wait_for(std::chrono::steady_clock::duration timeout) {
        TimedWaiter waiter{asio::steady_timer(executor_, timeout)};
        timed_.push_back(&waiter);
        co_await waiter.timer.async_wait(use_nothrow);
        std::erase(timed_, &waiter);
        co_return waiter.notified;
    }

private:
    struct TimedWaiter {
        asio::steady_timer timer;
        bool notified = false;
    };
    asio::any_io_executor executor_;
    std::vector<asio::any_completion_handler<void()>> handlers_;
    std::vector<TimedWaiter*> timed_;
};

}  // namespace plexus::daemon
