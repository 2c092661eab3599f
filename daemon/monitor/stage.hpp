#pragma once
// Threading: submit, in_flight, room, close, trig and run are called on the daemon's thread; the
// monitors run on the stage's strand (one worker at a time, in order); verdicts are handed back on
// the daemon's thread.
//
// Ownership: the chain's monitors (their Lua states) are touched only on the strand, from the
// moment the stage is made until close() lets them go there. The daemon's thread reads their
// counters for `plexus stats` (atomics; see monitor.hpp) and reaches them for `plexus param` through
// run(). Lock order: the stage's queue lock, then nothing; the arbiter's lock (taken by the scripts'
// event functions and by the arbitration after the monitors), then nothing. No lock is held while
// a script runs.

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>

#include "../arbitration/arbiter.hpp"
#include "../core/message_filter.hpp"
#include "../net/asio.hpp"
#include "chain.hpp"
#include "workers.hpp"

namespace plexus::daemon::monitor {

class MonitorStage final : public MessageFilter, public std::enable_shared_from_this<MonitorStage> {
public:
    struct Options {
        /// Messages held (waiting, running, or with a verdict on its way back) before the writer
        /// waits, as it waits for a full strict queue.
        std::size_t capacity = 1024;
        /// For destinations that never hold a writer back (latest queues, datagrams): when full,
        /// the oldest message not yet started is dropped and counted instead.
        bool drop_oldest = false;
    };

    /// `member`: the connection's place in its input port's arbitration (recv side); messages the
    /// monitors pass are admitted by it on the strand, right after them, as the monitors' events
    /// stand. Null on the send side.
    /// The stage keeps `workers` alive: its strand belongs to their pool, and a stage may be let go
    /// after the daemon (the last owner can be a handler the io_context destroys at exit).
    MonitorStage(std::shared_ptr<Workers> workers, asio::any_io_executor io,
                 std::shared_ptr<MonitorChain> chain, std::shared_ptr<arbitration::Member> member,
                 Options options, std::function<void()> on_space);

    /// Where verdicts go; set once the client exists.
    void attach(std::weak_ptr<FilterClient> client) { client_ = std::move(client); }

    void submit(const Message& message) override;
    std::size_t in_flight() const override { return in_flight_; }
    std::size_t room() const override;
    void close() override;

    /// Runs the trig of monitor `monitor_id` on the strand.
    void trig(std::uint64_t monitor_id);
    /// Runs `work` on the strand (with the monitors) and resumes the caller on its own executor.
    /// `work` does not run once the stage is closed.
    /// `work` must outlive the wait (a named local of the caller: g++ 12 mishandles temporaries in
    /// a co_await expression).
    Task<void> run(const std::function<void()>& work);

    /// For stats and param: the monitors themselves (see the threading note above).
    const MonitorChain& chain() const { return *chain_; }
    /// Messages dropped because the monitors fell behind a destination that never waits.
    std::uint64_t dropped_backlog() const { return dropped_backlog_; }

private:
    /// On the strand: runs the monitors over what waits, a slice at a time.
    void drain();
    Filtered process(const Message& message);
    /// The records of a batch one by one; runs of records passed unchanged stay batches.
    void process_batch(const Message& batch, std::vector<Filtered>& results);
    /// On the daemon's thread: hands verdicts to the client.
    void complete(std::vector<Filtered>& results);

    std::shared_ptr<Workers> workers_;  ///< before strand_: outlives it
    WorkerStrand strand_;
    asio::any_io_executor io_;
    std::shared_ptr<MonitorChain> chain_;
    std::shared_ptr<arbitration::Member> member_;
    Options options_;
    std::function<void()> on_space_;
    std::weak_ptr<FilterClient> client_;
    /// The client, held while messages are in the stage: a connection removed (its writer closed,
    /// or a disconnect) still gets every verdict of what it was given, as when monitors ran inline.
    std::shared_ptr<FilterClient> holding_;

    // The daemon's thread only.
    std::size_t in_flight_ = 0;
    std::uint64_t dropped_backlog_ = 0;

    // Shared with the strand, under mutex_.
    std::mutex mutex_;
    std::deque<Message> waiting_;
    bool draining_ = false;  ///< a drain is posted or running

    // The strand only.
    bool closed_ = false;
};

/// The stage behind a connection side's monitors (the only MessageFilter there is); null for none.
inline MonitorStage* stage_of(const std::shared_ptr<MessageFilter>& filter) {
    return static_cast<MonitorStage*>(filter.get());
}

}  // namespace plexus::daemon::monitor
