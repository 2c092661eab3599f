#pragma once
// Threading: made, started and stopped on the control thread. Shards::here(), counters() and the
// space calls run on any of the daemon's threads, each about its own shard; Shard::send() and
// Shard::post() on any thread. See handler_gate.hpp for who may touch what.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "../core/connection.hpp"
#include "../core/message.hpp"
#include "asio.hpp"
#include "daemon_counters.hpp"
#include "handler_gate.hpp"
#include "signal.hpp"

namespace plexus::daemon {

class ShardCrossing;

/// One of the daemon's threads: the control thread (number 0) or a data thread with the local
/// sessions pinned to it and their ports. Each has its counters, the signal its writers held back
/// wait on, and the mail other threads hand it for its ports (ShardCrossing).
class Shard : public std::enable_shared_from_this<Shard> {
public:
    /// The control thread's shard runs on `control`; a data thread's on an io_context of its own.
    Shard(std::size_t number, asio::io_context* control);
    ~Shard();

    std::size_t number() const { return number_; }
    asio::io_context& io() { return *io_; }
    DaemonCounters& counters() { return counters_; }
    const DaemonCounters& counters() const { return counters_; }

    /// Runs `work` on this shard's thread, in a handler of its own (dropped once it has stopped).
    void post(std::function<void()> work);
    /// A message for `crossing`'s sink, or its close when `close`: kept in order with everything
    /// else sent here, and handed over on this shard's thread.
    void send(std::shared_ptr<ShardCrossing> crossing, Message message, bool close);
    /// `crossing` found no room: it is told again once its sink here has some.
    void want_room(std::shared_ptr<ShardCrossing> crossing);
    /// On this shard's thread: `crossing` holds messages for a full sink here; they go in as room
    /// appears (space_appeared()).
    void hold(std::shared_ptr<ShardCrossing> crossing);

    /// On this shard's thread, before a writer looks for room: room appearing on another thread
    /// from now on wakes this shard's writers (poke()). The fence pairs with poke()'s: either the
    /// writer then sees the room published, or the thread that published it sees the writer
    /// waiting (without them both could miss the other, and the writer would sleep until its
    /// timeout). Only writers already held back come here.
    void expect_space() {
        writers_waiting_.store(true, std::memory_order_relaxed);
        std::atomic_thread_fence(std::memory_order_seq_cst);
    }
    /// On this shard's thread: waits at most `timeout` for room downstream; true if woken.
    Task<bool> wait_for_space(std::chrono::steady_clock::duration timeout);
    /// On this shard's thread: room appeared here. Lets in what crossings hold, then wakes its
    /// writers and the crossings of other shards that wait for room here.
    void space_appeared();
    /// From another thread: wakes this shard's writers if some wait, and looks again at the
    /// crossings that hold messages or wait for room here (a port closed on the control thread
    /// may have been their sink).
    void poke();

    /// Starts the data thread (not for the control shard).
    void start(ShardGates& gates);
    /// Stops the data thread, waits for it, and destroys its io_context and what that still
    /// holds (sessions that never closed), on the caller's thread: halt(), then dispose().
    void stop();
    /// Stops the data thread and waits for it; its io_context stays (others may still post to it).
    void halt();
    /// Destroys the halted thread's io_context and what it holds.
    void dispose();

private:
    struct Mail {
        std::shared_ptr<ShardCrossing> crossing;
        Message message;
        bool close = false;
    };
    /// On this shard's thread: hands over what was sent here, then answers room requests.
    void read_mail();
    void answer_room_requests();
    /// On this shard's thread: what crossings hold goes in while it fits.
    void release_held();
    /// Under mutex_: posts read_mail() unless it is posted already.
    void schedule_locked();

    std::size_t number_;
    std::unique_ptr<asio::io_context> own_io_;
    asio::io_context* io_;
    std::unique_ptr<asio::executor_work_guard<asio::io_context::executor_type>> work_;
    Signal space_;
    std::atomic<bool> writers_waiting_{false};
    std::vector<std::shared_ptr<ShardCrossing>> holding_;  ///< this thread's: crossings that hold messages
    std::atomic<bool> any_holding_{false};
    DaemonCounters counters_;
    ThreadRole role_;
    std::thread thread_;

    std::mutex mutex_;  ///< guards what follows
    std::vector<Mail> mail_;
    std::vector<std::shared_ptr<ShardCrossing>> room_wanted_;
    bool scheduled_ = false;
    bool stopped_ = false;
    std::atomic<bool> any_room_wanted_{false};
    std::vector<Mail> reading_;  ///< read_mail's, kept to reuse its storage
};

/// The daemon's threads (`--threads N`): with N = 1 the control thread does everything, as a
/// daemon of one thread; with N > 1 there are N data threads beside it, and local sessions are
/// pinned to them in turn.
class Shards {
public:
    Shards(asio::io_context& control, std::size_t threads);
    ~Shards();
    Shards(const Shards&) = delete;
    Shards& operator=(const Shards&) = delete;

    /// Data threads (0 when the control thread does everything).
    std::size_t data_threads() const { return shards_.size() - 1; }
    /// Gives the calling thread the control thread's role and starts the data threads.
    void start();
    /// Stops the data threads, then destroys what their io_contexts hold (sessions that never
    /// closed), on the caller's thread, while the daemon they refer to still exists.
    void stop();

    /// The shard a new local session goes to: the data threads in turn (0 without them).
    std::size_t place();
    Shard& operator[](std::size_t number) { return *shards_[number]; }
    const std::shared_ptr<Shard>& shared(std::size_t number) const { return shards_[number]; }
    /// The calling thread's shard: its data thread's number; 0 on the control thread and others.
    static std::size_t here();
    Shard& current() { return *shards_[here()]; }

    /// Every shard's counters added up.
    DaemonCounters total() const;
    /// Room appeared on this thread: see Shard::space_appeared(). The control thread also wakes
    /// the data threads' writers (a port closed, a link drained), and a data thread the control
    /// thread's (its sessions write into ports here directly).
    void space_appeared();

    // The control loop handed to a stand-in while the control thread finishes a long script
    // (monitor/loop_stand_in.hpp): the gates go with the loop.
    /// On the control thread, inside a handler: lets go of the gates it holds for it.
    void lend_gates() { gates_.release_all(); }
    /// On the stand-in's thread: its handlers take the gates as the control thread's do.
    void act_as_control() { this_thread_role = &stand_in_role_; }
    void stop_acting_as_control() { this_thread_role = nullptr; }
    /// On the control thread, once the stand-in stopped: holds the gates again for its handler.
    void reclaim_gates() { gates_.hold_all(); }

    /// The way from a port on `source` to `sink` when `sink` is on another data thread or on the
    /// control thread; null when the source may deliver to it directly.
    std::shared_ptr<MessageSink> crossing(std::size_t source, const std::shared_ptr<MessageSink>& sink);

private:
    std::vector<std::shared_ptr<Shard>> shards_;
    ShardGates gates_;
    ThreadRole stand_in_role_{&gates_, 0, 0};
    std::size_t next_ = 0;
    bool started_ = false;
};

}  // namespace plexus::daemon
