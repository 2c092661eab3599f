#pragma once
// Included by Boost.Asio itself: daemon/CMakeLists.txt names this file in
// BOOST_ASIO_CUSTOM_HANDLER_TRACKING for every library of the daemon, so every handler Asio runs
// (a completion, a posted function, a coroutine's resumption) passes through a HandlerGate. Only
// standard headers here: Asio's own are half-read when this is.
//
// Why. With `--threads N` (N > 1) the daemon moves data on N threads of their own (net/shards.hpp),
// each an io_context with local sessions pinned to it, while the rest -- the control plane, links
// to other daemons, udp, the name server, the web page, monitors' verdicts -- stays on the control
// thread, written for one thread and without locks. The gates keep that code right without
// changing it:
// - a data thread holds its own gate while it runs a handler;
// - the control thread holds every gate while it runs one.
// So a handler of the control thread never runs beside a data thread's: it may touch any port,
// session or connection. A data thread touches its own sessions and ports, and hands on what goes
// elsewhere (net/shard_crossing.hpp). Data threads run beside each other; the control thread
// waits between two of their handlers, which are short (a batch of frames).
//
// Threads without a role (monitor workers, the loop stand-in, test threads) take no gate: the stand-in
// runs the control loop only while the control thread, inside a handler, holds every gate for it
// (monitor/loop_stand_in.hpp).

#include <atomic>
#include <cstddef>
#include <mutex>
#include <vector>

namespace plexus::daemon {

/// The data threads' gates. The control thread takes its turn first: a busy data thread, which
/// takes its gate again right after letting it go, would otherwise keep the control thread (and
/// every request) waiting for as long as data flows.
class ShardGates {
public:
    /// Gates for data threads 1..count (0 is the control thread, which has none of its own).
    explicit ShardGates(std::size_t count) : gates_(count) {}
    ShardGates(const ShardGates&) = delete;
    ShardGates& operator=(const ShardGates&) = delete;

    void hold_all() {
        turn_.lock();
        control_waits_.store(true, std::memory_order_release);
        for (auto& gate : gates_)
            gate.lock();
    }
    void release_all() {
        for (auto it = gates_.rbegin(); it != gates_.rend(); ++it)
            it->unlock();
        control_waits_.store(false, std::memory_order_release);
        turn_.unlock();
    }
    void hold(std::size_t shard) {
        if (control_waits_.load(std::memory_order_acquire)) {
            // Let the control thread have its handler first.
            turn_.lock();
            turn_.unlock();
        }
        gates_[shard - 1].lock();
    }
    void release(std::size_t shard) { gates_[shard - 1].unlock(); }

private:
    std::mutex turn_;  ///< the control thread's while it takes or holds the gates
    std::atomic<bool> control_waits_{false};
    std::vector<std::mutex> gates_;
};

/// What a thread is to the gates: the control thread (shard 0) or data thread `shard`.
struct ThreadRole {
    ShardGates* gates = nullptr;
    std::size_t shard = 0;
    int depth = 0;  ///< handlers run inside handlers (a dispatch run inline): held once
};

/// Null on threads without a role.
inline thread_local ThreadRole* this_thread_role = nullptr;

/// True on a data thread: what belongs to the control thread must be posted to it from here.
inline bool on_data_thread() {
    return this_thread_role && this_thread_role->shard != 0;
}

/// One handler's hold on the gates: taken when Asio invokes the handler, given back when the
/// operation that ran it ends.
class HandlerGate {
public:
    HandlerGate() = default;
    HandlerGate(const HandlerGate&) = delete;
    HandlerGate& operator=(const HandlerGate&) = delete;
    ~HandlerGate() {
        if (!held_ || --held_->depth > 0)
            return;
        if (held_->shard == 0)
            held_->gates->release_all();
        else
            held_->gates->release(held_->shard);
    }

    void enter() {
        ThreadRole* role = this_thread_role;
        if (!role || held_)
            return;
        held_ = role;
        if (role->depth++ > 0)
            return;
        if (role->shard == 0)
            role->gates->hold_all();
        else
            role->gates->hold(role->shard);
    }

private:
    ThreadRole* held_ = nullptr;
};

}  // namespace plexus::daemon

// The hooks Asio asks a custom tracking header for (boost/asio/detail/handler_tracking.hpp). Only
// the completion and invocation ones do something.
#define BOOST_ASIO_INHERIT_TRACKED_HANDLER
#define BOOST_ASIO_ALSO_INHERIT_TRACKED_HANDLER
#define BOOST_ASIO_HANDLER_TRACKING_INIT (void)0
#define BOOST_ASIO_HANDLER_LOCATION(args) (void)0
#define BOOST_ASIO_HANDLER_CREATION(args) (void)0
#define BOOST_ASIO_HANDLER_COMPLETION(args) ::plexus::daemon::HandlerGate plexus_handler_gate_
#define BOOST_ASIO_HANDLER_INVOCATION_BEGIN(args) plexus_handler_gate_.enter()
#define BOOST_ASIO_HANDLER_INVOCATION_END (void)0
#define BOOST_ASIO_HANDLER_OPERATION(args) (void)0
#define BOOST_ASIO_HANDLER_REACTOR_REGISTRATION(args) (void)0
#define BOOST_ASIO_HANDLER_REACTOR_DEREGISTRATION(args) (void)0
#define BOOST_ASIO_HANDLER_REACTOR_READ_EVENT 1
#define BOOST_ASIO_HANDLER_REACTOR_WRITE_EVENT 2
#define BOOST_ASIO_HANDLER_REACTOR_ERROR_EVENT 4
#define BOOST_ASIO_HANDLER_REACTOR_EVENTS(args) (void)0
#define BOOST_ASIO_HANDLER_REACTOR_OPERATION(args) (void)0
