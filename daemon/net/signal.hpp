#pragma once
// Threading: one io_context thread; notify() and the waits run on it.

#include <algorithm>
#include <chrono>
#include <mutex>
#include <vector>

#include <boost/asio/any_completion_handler.hpp>

#include "asio.hpp"

namespace plexus::daemon {

class Signal;

/// The parked waits of every Signal of one io_context. A parked wait is not in the io_context's
/// queue, so the io_context cannot destroy it: a coroutine parked on a Signal of an object that the
/// coroutine itself keeps alive (a connection's loop holding shared_from_this()) is a cycle that
/// nothing frees, and its frames leaked at every exit (LeakSanitizer). destroy_parked() destroys
/// them all, as asio destroys its own pending operations; the daemon calls it when its io_context
/// stops, and shutdown() (the io_context's destruction) does it for everyone else.
class SignalService : public asio::execution_context::service {
public:
    static inline asio::execution_context::id id;
    explicit SignalService(asio::execution_context& context) : service(context) {}

    void add(Signal* signal) {
        std::lock_guard lock(mutex_);
        signals_.push_back(signal);
    }
    void remove(Signal* signal) {
        std::lock_guard lock(mutex_);
        std::erase(signals_, signal);
    }
    /// Destroys the parked waits (and so the coroutine frames) of every Signal. Frames destroyed
    /// may destroy their owners, and with them other Signals: those leave the list on their own.
    inline void destroy_parked();

private:
    inline void shutdown() override;

    std::mutex mutex_;
    std::vector<Signal*> signals_;
};

/// Wakes every coroutine waiting on it. Waiters re-check their condition in a loop, so a notify with
/// nobody waiting is harmless (single thread: nothing runs between the check and the wait).
///
/// wait() parks the coroutine's completion handler and notify() posts it: no timer, so no timerfd
/// system calls on the per-message path (a steady_timer at time_point::max() cost one or two per
/// wake-up). wait_for() uses a timer, for the rarer waits that need a deadline.
class Signal {
public:
    explicit Signal(asio::any_io_executor executor)
        : executor_(std::move(executor)),
          service_(&asio::use_service<SignalService>(asio::query(executor_, asio::execution::context))) {
        service_->add(this);
    }
    ~Signal() {
        if (service_)
            service_->remove(this);
    }
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
    friend class SignalService;
    struct TimedWaiter {
        asio::steady_timer timer;
        bool notified = false;
    };
    asio::any_io_executor executor_;
    SignalService* service_;
    std::vector<asio::any_completion_handler<void()>> handlers_;
    std::vector<TimedWaiter*> timed_;
};

inline void SignalService::destroy_parked() {
    std::vector<asio::any_completion_handler<void()>> parked;
    {
        std::lock_guard lock(mutex_);
        for (auto* signal : signals_) {
            std::move(signal->handlers_.begin(), signal->handlers_.end(), std::back_inserter(parked));
            signal->handlers_.clear();
        }
    }
    parked.clear();  // outside the lock: the frames' destructors may destroy Signals
}

inline void SignalService::shutdown() {
    destroy_parked();
    // A Signal that outlives its io_context must not come back to this service.
    std::lock_guard lock(mutex_);
    for (auto* signal : signals_)
        signal->service_ = nullptr;
    signals_.clear();
}

}  // namespace plexus::daemon
