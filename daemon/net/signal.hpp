#pragma once
// Threading: one io_context thread; notify() and wait() run on it.

#include <chrono>

#include "asio.hpp"

namespace plexus::daemon {

/// Wakes every coroutine waiting on it. Waiters re-check their condition in a loop, so a notify with
/// nobody waiting is harmless (single thread: nothing runs between the check and the wait).
class Signal {
public:
    explicit Signal(const asio::any_io_executor& executor) : timer_(executor) {
        timer_.expires_at(asio::steady_timer::time_point::max());
    }
    void notify() {
        if (waiters_ > 0) timer_.cancel();
    }
    Task<void> wait() {
        timer_.expires_at(asio::steady_timer::time_point::max());
        ++waiters_;
        co_await timer_.async_wait(use_nothrow);
        --waiters_;
    }
    /// Waits at most `timeout`; true if notified (or cancelled), false on timeout.
    Task<bool> wait_for(std::chrono::steady_clock::duration timeout) {
        using namespace asio::experimental::awaitable_operators;
        asio::steady_timer deadline(timer_.get_executor(), timeout);
        auto result = co_await (wait() || deadline.async_wait(use_nothrow));
        co_return result.index() == 0;
    }

private:
    asio::steady_timer timer_;
    int waiters_ = 0;
};

}  // namespace plexus::daemon
