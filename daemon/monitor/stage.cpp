#include "stage.hpp"

#include <limits>

#include <boost/asio/post.hpp>

#include "../core/batch.hpp"

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
      io_(std::move(io)),
      chain_(std::move(chain)),
      member_(std::move(member)),
      options_(options),
      on_space_(std::move(on_space)) {}

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
        asio::post(strand_, [self = shared_from_this()] { self->drain(); });
}

void MonitorStage::drain() {
    std::vector<Filtered> results;
    const auto started = std::chrono::steady_clock::now();
    bool more = true;
    while (more) {
        Message message;
        {
            std::lock_guard lock(mutex_);
            if (waiting_.empty()) {
                draining_ = false;
                more = false;
                break;
            }
            message = std::move(waiting_.front());
            waiting_.pop_front();
        }
        if (message.batch == 0)
            results.push_back(process(message));
        else
            process_batch(message, results);
        if (results.size() >= slice_messages || std::chrono::steady_clock::now() - started >= slice_time)
            break;
    }
    if (!results.empty()) {
        asio::post(io_, [self = shared_from_this(), results = std::move(results)]() mutable {
            self->complete(results);
        });
    }
    if (more)  // the rest after whatever else waits for a worker
        asio::post(strand_, [self = shared_from_this()] { self->drain(); });
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
        if (verdict.verdict != FilterVerdict::pass || !unchanged) {
            end_run();  // dropped, refused or rewritten: a message of its own
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
    t_publish_depth = message.publish_depth;
    const bool passed = chain_->process(out.message);
    t_publish_depth = 0;
    if (!passed) {
        out.verdict = FilterVerdict::dropped;
        return out;
    }
    if (member_) {
        std::lock_guard lock(member_->arbiter().mutex());
        if (!member_->trivial() &&
            member_->arbiter().admit(*member_) != arbitration::Arbiter::Verdict::deliver)
            out.verdict = FilterVerdict::refused;
    }
    return out;
}

void MonitorStage::complete(std::vector<Filtered>& results) {
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
        self->closed_ = true;
        self->chain_->monitors.clear();  // their destroy callbacks run here, on their thread
        std::lock_guard lock(self->mutex_);
        self->waiting_.clear();
    });
}

void MonitorStage::trig(std::uint64_t monitor_id) {
    asio::post(strand_, [self = shared_from_this(), monitor_id] {
        if (self->closed_)
            return;
        for (auto& monitor : self->chain_->monitors) {
            if (monitor->id() == monitor_id)
                monitor->trig();
        }
    });
}

Task<void> MonitorStage::run(const std::function<void()>& work) {
    // Named, not a temporary inside the co_await: g++ 12 destroys the captures of such a lambda
    // twice (a shared_ptr capture freed the stage under its owner).
    auto initiation = [self = shared_from_this(), &work](auto handler) {
        auto shared = std::make_shared<decltype(handler)>(std::move(handler));
        asio::post(self->strand_, [self, &work, shared] {
            if (!self->closed_)
                work();
            auto executor = asio::get_associated_executor(*shared);
            asio::post(executor, std::move(*shared));
        });
    };
    co_await asio::async_initiate<const asio::use_awaitable_t<>, void()>(initiation, asio::use_awaitable);
}

}  // namespace plexus::daemon::monitor
