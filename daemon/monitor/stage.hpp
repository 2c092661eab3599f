#pragma once
// Threading: submit, in_flight, room, close, trig and run are called on the daemon's thread; the
// monitors run either inline on the daemon's thread (in a handler of their own, while they are
// cheap) or on the stage's strand (one worker at a time, in order); verdicts are handed to the
// client on the daemon's thread.
//
// Inline or on a worker: a worker costs each message two thread wake-ups (there and back), tens of
// microseconds on an idle virtual machine, far more than a cheap script. So a stage starts inline
// and moves its monitors to the strand when their cost per message (a moving average) grows past
// Options::inline_cost_limit, and back when it falls under half of it. An inline script that runs past
// `inline_overrun_after` (counted from the drain's start) has the event loop taken over by the
// LoopStandIn (loop_stand_in.hpp) for the rest of its call, and its stage goes to the strand until
// its cost there is low again: whatever a script does, the daemon's other work waits at most that
// long plus one look at the clock (a few microseconds of script) per inline drain.
// Compiled monitors always run on the strand: nothing can look at the clock inside them.
//
// Ownership: the chain's monitors (their Lua states) are touched only under monitors_mutex_, which
// an inline drain takes with try_lock (and gives way to the strand if it cannot) and strand work
// takes outright; at most one drain of either kind exists at a time (draining_), and an inline
// drain waits for the verdicts a strand drain posted before it (strand_reports_pending_). The
// daemon's thread reads their counters for `plexus stats` (atomics; see monitor.hpp) and reaches
// them for `plexus param` through run(). Lock order: monitors_mutex_, then the stage's queue lock
// or the arbiter's lock (taken by the scripts' event functions and by the arbitration after the
// monitors), then nothing. No lock but monitors_mutex_ is held while a script runs.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>

#include "../arbitration/arbiter.hpp"
#include "../core/latency_histogram.hpp"
#include "../core/message_filter.hpp"
#include "../net/asio.hpp"
#include "chain.hpp"
#include "loop_stand_in.hpp"
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
        /// Past this cost per message (a moving average), the monitors go to a worker (see above);
        /// zero: never inline.
        std::chrono::microseconds inline_cost_limit{10};
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
    bool sees_replies() const override { return sees_replies_; }
    void reply(Message answer, std::function<void(Message)> done) override;

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
    /// Whether the monitors run inline now, and how many inline calls overran (see above).
    bool runs_inline() const { return inline_now_; }
    std::uint64_t inline_overruns() const { return inline_overruns_; }
    /// What running the monitors cost per message, inline or on a worker (daemon's thread).
    const LatencyHistogram& cost_histogram() const { return cost_histogram_; }

    /// An inline drain takes no more messages after this long...
    static constexpr auto inline_batch_time = std::chrono::microseconds(50);
    /// ...and a script still running this long after the drain began has the loop taken over.
    static constexpr auto inline_overrun_after = std::chrono::microseconds(200);

private:
    using Clock = std::chrono::steady_clock;
    /// A stand-in exists, inline is not off, and every monitor is a script.
    bool may_run_inline() const;
    /// Where the next drain runs: inline (a handler on the daemon's thread) or on the strand.
    void schedule_drain();
    /// On the strand: runs the monitors over what waits, a slice at a time.
    void drain();
    /// On the daemon's thread: the same, inline, a short slice at a time.
    void drain_inline();
    struct Drained {
        std::size_t messages = 0;
        bool more = false;  ///< messages still wait: draining_ stays set, another drain is due
    };
    /// Under monitors_mutex_: processes waiting messages until none waits or `until` has passed.
    Drained process_waiting(std::vector<Filtered>& results, Clock::time_point until,
                            std::size_t most = std::numeric_limits<std::size_t>::max());
    Filtered process(const Message& message);
    /// The records of a batch one by one; runs of records passed unchanged stay batches.
    void process_batch(const Message& batch, std::vector<Filtered>& results);
    /// On the daemon's thread: hands verdicts to the client; `took` the monitors' time for them.
    void complete(std::vector<Filtered>& results, Clock::duration took, std::size_t messages);
    /// On the daemon's thread: the moving average of the cost per message, and inline or not.
    void note_cost(Clock::duration took, std::size_t messages);

    std::shared_ptr<Workers> workers_;  ///< before strand_: outlives it
    WorkerStrand strand_;
    LoopStandIn* stand_in_;  ///< the workers' (null: never inline)
    asio::any_io_executor io_;
    bool sees_replies_ = false;  ///< some monitor has PortMonitor.reply (fixed at creation)
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
    bool inline_now_ = false;
    std::uint64_t inline_overruns_ = 0;
    LatencyHistogram cost_histogram_;
    double cost_ns_ = -1;  ///< moving average of the monitors' time per message; negative: none yet

    /// Held while the monitors run (see the ownership note above).
    std::mutex monitors_mutex_;
    /// Verdicts a strand drain posted to the daemon's thread, not yet handed over there: counted
    /// up under monitors_mutex_, down on the daemon's thread. An inline drain waits while any are
    /// pending, so that verdicts reach the client in the order their messages came.
    std::atomic<std::size_t> strand_reports_pending_{0};

    // Shared with the strand, under mutex_.
    std::mutex mutex_;
    std::deque<Message> waiting_;
    bool draining_ = false;  ///< a drain is posted or running

    // Under monitors_mutex_.
    bool closed_ = false;
};

/// The stage behind a connection side's monitors (the only MessageFilter there is); null for none.
inline MonitorStage* stage_of(const std::shared_ptr<MessageFilter>& filter) {
    return static_cast<MonitorStage*>(filter.get());
}

}  // namespace plexus::daemon::monitor
