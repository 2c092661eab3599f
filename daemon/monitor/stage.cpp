#include "stage.hpp"

#include <algorithm>
#include <limits>

#include <spdlog/spdlog.h>
#include <boost/asio/post.hpp>

#include "../core/batch.hpp"
#include "../core/call_ticket.hpp"

namespace plexus::daemon::monitor {

namespace {

/// A drain hands its verdicts back and lets other strands have the worker after this many
/// messages or this long, whichever comes first: one busy connection cannot hold a worker.
constexpr std::size_t slice_messages = 64;
constexpr auto slice_time = std::chrono::milliseconds(2);

thread_local int t_publish_depth = 0;

}  // namespace

int current_publish_depth() {
    return t_publish_depth;
}

MonitorStage::MonitorStage(std::shared_ptr<Workers> workers, asio::any_io_executor io,
                           std::shared_ptr<MonitorChain> chain, std::shared_ptr<arbitration::Member> member,
                           Options options, std::function<void()> on_space)
    : workers_(std::move(workers)),
      strand_(workers_->make_strand()),
      stand_in_(workers_->stand_in()),
      io_(std::move(io)),
      chain_(std::move(chain)),
      member_(std::move(member)),
      options_(options),
      on_space_(std::move(on_space)) {
    inline_now_ = may_run_inline();
    sees_replies_ = chain_->has_reply();
}

bool MonitorStage::may_run_inline() const {
    return stand_in_ != nullptr && options_.inline_cost_limit.count() > 0 && chain_->interruptible();
}

std::size_t MonitorStage::room() const {
    if (options_.drop_oldest)
        return std::numeric_limits<std::size_t>::max();
    return in_flight_ < options_.capacity ? options_.capacity - in_flight_ : 0;
}

void MonitorStage::submit(const Message& message) {
    if (in_flight_ == 0)
        holding_ = client_.lock();
    in_flight_ += message.count();
    bool start = false;
    std::uint64_t dropped = 0;
    {
        std::lock_guard lock(mutex_);
        if (options_.drop_oldest && waiting_.size() >= options_.capacity) {
            dropped = waiting_.front().count();
            waiting_.pop_front();
        }
        waiting_.push_back(message);
        start = !draining_;
        draining_ = true;
    }
    in_flight_ -= dropped;
    dropped_backlog_ += dropped;
    if (in_flight_ == 0)
        holding_.reset();
    if (start)
        schedule_drain();
}

void MonitorStage::schedule_drain() {
    // Inline drains are handlers of their own, not calls from here: the caller's frames (a
    // session's read, a router) must not be on the stack if the loop is taken over meanwhile.
    if (inline_now_ && !stand_in_->stepped_in())
        asio::post(io_, [self = shared_from_this()] { self->drain_inline(); });
    else
        asio::post(strand_, [self = shared_from_this()] { self->drain(); });
}

MonitorStage::Drained MonitorStage::process_waiting(std::vector<Filtered>& results, Clock::time_point until,
                                                    std::size_t most) {
    Drained drained;
    for (;;) {
        Message message;
        {
            std::lock_guard lock(mutex_);
            if (waiting_.empty()) {
                draining_ = false;
                return drained;
            }
            message = std::move(waiting_.front());
            waiting_.pop_front();
        }
        drained.messages += message.count();
        if (message.batch == 0)
            results.push_back(process(message));
        else
            process_batch(message, results);
        if (results.size() >= most || Clock::now() >= until) {
            std::lock_guard lock(mutex_);
            drained.more = !waiting_.empty();
            if (!drained.more)
                draining_ = false;
            return drained;
        }
    }
}

void MonitorStage::drain() {
    std::vector<Filtered> results;
    const auto started = Clock::now();
    Drained drained;
    {
        std::lock_guard monitors(monitors_mutex_);
        drained = process_waiting(results, started + slice_time, slice_messages);
        // Posted before the monitors are let go: an inline drain, which can only start after
        // that, sees the report pending and waits for it (see drain_inline).
        if (!results.empty() || drained.messages > 0) {
            const auto took = Clock::now() - started;
            ++strand_reports_pending_;
            asio::post(io_, [self = shared_from_this(), results = std::move(results), took,
                             messages = drained.messages]() mutable {
                --self->strand_reports_pending_;
                self->complete(results, took, messages);
            });
        }
    }
    if (drained.more)  // the rest after whatever else waits for a worker
        asio::post(strand_, [self = shared_from_this()] { self->drain(); });
}

void MonitorStage::drain_inline() {
    std::unique_lock monitors(monitors_mutex_, std::try_to_lock);
    if (!monitors.owns_lock() || stand_in_->stepped_in()) {
        // A trig or a param call has the monitors on the strand now, or the stand-in has the loop
        // (it must not hand over in turn): these messages go to the strand.
        asio::post(strand_, [self = shared_from_this()] { self->drain(); });
        return;
    }
    if (strand_reports_pending_ > 0) {
        // The strand's verdicts for earlier messages are still on their way to this loop: these
        // messages' verdicts, handed over at once, would pass them. After them, then.
        monitors.unlock();
        asio::post(io_, [self = shared_from_this()] { self->drain_inline(); });
        return;
    }
    std::vector<Filtered> results;
    const auto started = Clock::now();
    LuaSandbox::InlineSlice slice{started + inline_overrun_after, [this] { stand_in_->take_over(); }};
    LuaSandbox::watch_inline_slice(&slice);
    const auto drained = process_waiting(results, started + inline_batch_time, slice_messages);
    LuaSandbox::watch_inline_slice(nullptr);
    // Named under the lock: once it is let go, the strand may close the stage and free the chain.
    const std::string overran_monitors = !slice.overran || chain_->monitors.empty()
                                             ? std::string("a connection")
                                             : chain_->monitors.front()->description();
    monitors.unlock();
    if (slice.overran) {
        stand_in_->give_back();  // from here on this thread has the loop again
        ++inline_overruns_;
        // On a worker until their measured cost there says they are cheap again (a long way down
        // from here: a script that keeps overrunning never comes back).
        cost_ns_ = std::max(cost_ns_, std::chrono::duration<double, std::nano>(inline_overrun_after).count());
        inline_now_ = false;
        spdlog::warn(
            "monitors of {} ran past {} us on the daemon's thread; the event loop went on "
            "without them, and they run on a worker until they are cheap again",
            overran_monitors,
            std::chrono::duration_cast<std::chrono::microseconds>(inline_overrun_after).count());
    }
    complete(results, Clock::now() - started, drained.messages);
    if (drained.more)
        schedule_drain();
}

void MonitorStage::note_cost(Clock::duration took, std::size_t messages) {
    if (messages == 0)
        return;
    const double per_message =
        std::chrono::duration<double, std::nano>(took).count() / static_cast<double>(messages);
    cost_ns_ = cost_ns_ < 0 ? per_message : cost_ns_ + (per_message - cost_ns_) / 8;
    cost_histogram_.observe(per_message * 1e-9, messages);
    const double limit = std::chrono::duration<double, std::nano>(options_.inline_cost_limit).count();
    if (inline_now_ && cost_ns_ > limit)
        inline_now_ = false;
    else if (!inline_now_ && may_run_inline() && cost_ns_ < limit / 2)
        inline_now_ = true;
}

void MonitorStage::process_batch(const Message& batch, std::vector<Filtered>& results) {
    // The monitors see every record on its own; the records they pass unchanged, one after the
    // other, go on together as a smaller batch (the bytes of a run of records are contiguous), so
    // that a filter that passes most messages does not cost a queue entry and a frame per message.
    const std::uint8_t* run_begin = nullptr;
    const std::uint8_t* run_end = nullptr;
    std::uint32_t run_count = 0;
    auto end_run = [&] {
        if (run_count > 0)
            results.push_back(
                {Message{batch.storage, {run_begin, run_end}, 0, run_count}, FilterVerdict::pass});
        run_count = 0;
    };
    proto::BatchRecords records(batch.record, batch.batch);
    for (;;) {
        const std::uint8_t* entry_begin = records.rest().data();
        const auto record = records.next();
        if (!record)
            break;
        Message single{batch.storage, *record, 0, 0};
        single.publish_depth = batch.publish_depth;
        auto verdict = process(single);
        const bool unchanged = verdict.message.record.data() == record->data() &&
                               verdict.message.record.size() == record->size();
        if (verdict.verdict != FilterVerdict::pass || !unchanged || verdict.decision_time != 0) {
            end_run();  // dropped, refused, rewritten or timed for a tap: a message of its own
            results.push_back(std::move(verdict));
            continue;
        }
        if (run_count == 0)
            run_begin = entry_begin;
        run_end = records.rest().data();
        ++run_count;
    }
    end_run();
}

Filtered MonitorStage::process(const Message& message) {
    Filtered out{message, FilterVerdict::pass};
    if (closed_) {
        out.verdict = FilterVerdict::dropped;  // nobody takes it any more
        return out;
    }
    // A tap records the instants of both steps (one clock reading each), only while it listens.
    const bool timed = member_ && member_->arbiter().watched();
    if (timed)
        out.monitor_time = member_->arbiter().now();
    t_publish_depth = message.publish_depth;
    const bool passed = chain_->process(out.message);
    t_publish_depth = 0;
    // A request stays one when a monitor rewrote it (update makes a new message): its ticket goes on.
    out.message.call = message.call;
    if (!passed) {
        if (message.call)
            message.call->set_drop_reason("dropped by a monitor's accept (or its error) on the way");
        out.verdict = FilterVerdict::dropped;
        if (timed)
            out.decision_time = member_->arbiter().now();
        return out;
    }
    if (member_) {
        auto& arbiter = member_->arbiter();
        std::lock_guard lock(arbiter.mutex());
        if (!member_->trivial()) {
            const double now = arbiter.now();
            out.arbitration = arbiter.admit(*member_, now);
            if (out.arbitration != arbitration::Arbiter::Verdict::deliver) {
                out.verdict = FilterVerdict::refused;
                if (message.call)
                    message.call->set_drop_reason(std::string("refused by the server port's arbitration (") +
                                                  arbitration::Arbiter::verdict_name(out.arbitration) + ")");
            }
            if (timed)
                out.decision_time = now;
        } else if (timed) {
            out.decision_time = arbiter.now();
        }
    }
    return out;
}

void MonitorStage::complete(std::vector<Filtered>& results, Clock::duration took, std::size_t messages) {
    note_cost(took, messages);
    for (const auto& result : results)
        in_flight_ -= result.message.count();
    if (auto client = client_.lock())
        client->filtered(results);
    if (on_space_)
        on_space_();
    if (in_flight_ == 0)
        holding_.reset();  // may end the client, and with it this stage's monitors (close())
}

void MonitorStage::close() {
    client_.reset();
    holding_.reset();
    asio::post(strand_, [self = shared_from_this()] {
        std::lock_guard monitors(self->monitors_mutex_);
        self->closed_ = true;
        self->chain_->monitors.clear();  // their destroy callbacks run here, on their thread
        std::lock_guard lock(self->mutex_);
        self->waiting_.clear();
    });
}

void MonitorStage::trig(std::uint64_t monitor_id) {
    asio::post(strand_, [self = shared_from_this(), monitor_id] {
        std::lock_guard monitors(self->monitors_mutex_);
        if (self->closed_)
            return;
        for (auto& monitor : self->chain_->monitors) {
            if (monitor->id() == monitor_id)
                monitor->trig();
        }
    });
}

void MonitorStage::reply(Message answer, std::function<void(Message)> done) {
    asio::post(strand_,
               [self = shared_from_this(), answer = std::move(answer), done = std::move(done)]() mutable {
                   {
                       std::lock_guard monitors(self->monitors_mutex_);
                       if (!self->closed_)
                           self->chain_->reply(answer);
                   }
                   asio::post(self->io_, [answer = std::move(answer), done = std::move(done)]() mutable {
                       done(std::move(answer));
                   });
               });
}

Task<void> MonitorStage::run(const std::function<void()>& work) {
    // Named, not a temporary inside the co_await: g++ 12 destroys the captures of such a lambda
    // twice (a shared_ptr capture freed the stage under its owner).
    auto initiation = [self = shared_from_this(), &work](auto handler) {
        auto shared = std::make_shared<decltype(handler)>(std::move(handler));
        asio::post(self->strand_, [self, &work, shared] {
            {
                std::lock_guard monitors(self->monitors_mutex_);
                if (!self->closed_)
                    work();
            }
            auto executor = asio::get_associated_executor(*shared);
            asio::post(executor, std::move(*shared));
        });
    };
    co_await asio::async_initiate<const asio::use_awaitable_t<>, void()>(initiation, asio::use_awaitable);
}

}  // namespace plexus::daemon::monitor
