#include "call_table.hpp"

#include <cstring>

#include <spdlog/spdlog.h>

#include "framed_connection.hpp"
#include "handler_gate.hpp"

namespace plexus::daemon {

namespace {
/// How many finished calls are remembered, to tell a late answer from a duplicate one.
constexpr std::size_t remembered_calls = 4096;

}  // namespace

std::shared_ptr<CallTicket> CallTable::start(const std::shared_ptr<FramedConnection>& back,
                                             std::uint64_t back_id, Clock::time_point deadline,
                                             std::string what, const std::shared_ptr<Port>& port,
                                             std::vector<std::shared_ptr<MessageFilter>> reply_through) {
    if (port->calls_outstanding >= max_calls_per_port) {
        ++counters_.busy;
        return nullptr;
    }
    ++port->calls_outstanding;
    const std::uint64_t id = next_id_++;
    Entry entry{back, back_id, nullptr, deadline, std::move(what), port, {}};
    for (auto& stage : reply_through) {
        if (stage && stage->sees_replies())
            entry.reply_through.push_back(stage);
    }
    entries_.emplace(id, std::move(entry));
    deadlines_.emplace(deadline, id);
    ++counters_.started;
    back->carry_calls(shared_from_this());
    arm_timer();
    return std::make_shared<CallTicket>(id, deadline, std::weak_ptr<CallRoutes>(shared_from_this()));
}

void CallTable::dropped(std::uint64_t id, std::string reason) {
    // The ticket may end on a monitor worker: its end comes back to this thread.
    std::weak_ptr<CallTable> weak = weak_from_this();
    asio::post(executor_, [weak, id, reason = std::move(reason)] {
        if (auto table = weak.lock()) {
            const auto entry = table->entries_.find(id);
            if (entry != table->entries_.end() && !entry->second.out)
                table->fail(id, proto::CallOutcome::refused, reason);
        }
    });
}

void CallTable::refuse(FramedConnection& back, std::uint64_t back_id, std::string_view reason) {
    ++counters_.started;
    ++counters_.refused;
    proto::Bytes frame;
    proto::append_failed_answer_frame(frame, back_id, proto::CallOutcome::refused, reason);
    back.send(std::move(frame));
}

void CallTable::handed_on(std::uint64_t id, const std::shared_ptr<FramedConnection>& out) {
    if (on_data_thread()) {
        // Written by a session of a data thread (`--threads`): the table is the control thread's.
        // Its answer, which that session hands to the control thread too, comes after this.
        std::weak_ptr<CallTable> weak = weak_from_this();
        asio::post(executor_, [weak, id, out] {
            if (auto table = weak.lock())
                table->handed_on(id, out);
        });
        return;
    }
    const auto entry = entries_.find(id);
    if (entry == entries_.end())
        return;  // failed meanwhile (its deadline passed while it waited in a queue)
    if (out->closed()) {
        // Posted by a data thread, and the socket closed before this ran: it will not tell us.
        fail(id, proto::CallOutcome::lost,
             "the server went away with the call (" + out->description() + " closed)");
        return;
    }
    entry->second.out = out.get();
    out->carry_calls(shared_from_this());
}

void CallTable::answer(FramedConnection& from, const proto::AnswerView& answer) {
    const auto entry = entries_.find(answer.id);
    if (entry == entries_.end() || entry->second.out != &from) {
        // Only the socket a call left on may answer it: anyone else could answer calls that were
        // never theirs.
        const auto finished = finished_.find(answer.id);
        if (entry != entries_.end() || finished == finished_.end() || finished->second.out != &from)
            ++counters_.unknown_answers;
        else if (finished->second.answered)
            ++counters_.duplicate_answers;
        else
            ++counters_.late_answers;
        return;
    }
    const Entry& call = entry->second;
    auto back = call.back.lock();
    if (!back || back->closed()) {
        ++counters_.caller_gone;
    } else if (answer.outcome == proto::CallOutcome::ok && !call.reply_through.empty()) {
        ++counters_.answered;
        // The answer passes the monitors that look at replies (PortMonitor.reply) on its way back.
        auto chunk = std::make_shared<Chunk>(answer.record.size());
        std::memcpy(chunk->data(), answer.record.data(), answer.record.size());
        const proto::ByteView record(chunk->data(), chunk->size);
        pass_back(back, call.back_id, Message{std::move(chunk), record}, call.reply_through, 0);
    } else {
        ++counters_.answered;
        proto::Bytes frame;
        if (answer.outcome == proto::CallOutcome::ok)
            proto::append_answer_frame(frame, call.back_id, answer.record);
        else
            proto::append_failed_answer_frame(frame, call.back_id, answer.outcome, answer.reason);
        back->send(std::move(frame));
    }
    finish(answer.id, true);
}

void CallTable::pass_back(std::weak_ptr<FramedConnection> back, std::uint64_t back_id, Message answer,
                          std::vector<std::weak_ptr<MessageFilter>> through, std::size_t next) {
    while (next < through.size()) {
        if (auto stage = through[next++].lock()) {
            stage->reply(std::move(answer), [back = std::move(back), back_id, through = std::move(through),
                                             next](Message passed) mutable {
                pass_back(std::move(back), back_id, std::move(passed), std::move(through), next);
            });
            return;
        }
    }
    auto to = back.lock();
    if (!to || to->closed())
        return;  // the caller left while the monitors looked at its answer
    proto::Bytes frame;
    proto::append_answer_frame(frame, back_id, answer.record);
    to->send(std::move(frame));
}

void CallTable::closed(const FramedConnection& connection) {
    if (on_data_thread()) {
        // A session of a data thread closed: the table is the control thread's (see handed_on).
        std::weak_ptr<CallTable> weak = weak_from_this();
        asio::post(executor_, [weak, gone = connection.shared_from_this()] {
            if (auto table = weak.lock())
                table->closed(*gone);
        });
        return;
    }
    std::vector<std::uint64_t> lost;
    std::vector<std::uint64_t> orphaned;
    for (const auto& [id, entry] : entries_) {
        if (entry.out == &connection)
            lost.push_back(id);
        else if (auto back = entry.back.lock(); !back || back.get() == &connection)
            orphaned.push_back(id);
    }
    for (const auto id : lost) {
        fail(id, proto::CallOutcome::lost,
             "the server went away with the call (" + connection.description() + " closed)");
    }
    for (const auto id : orphaned) {
        // The caller is gone: the request goes on (it may have effects), its answer will not.
        auto& entry = entries_.at(id);
        entry.back.reset();
    }
}

void CallTable::fail(std::uint64_t id, proto::CallOutcome outcome, std::string_view reason) {
    const auto entry = entries_.find(id);
    if (entry == entries_.end())
        return;
    switch (outcome) {
        case proto::CallOutcome::timeout:
            ++counters_.timed_out;
            break;
        case proto::CallOutcome::lost:
            ++counters_.lost;
            break;
        default:
            ++counters_.refused;
            break;
    }
    send_failure(entry->second, outcome, reason);
    finish(id, false);
}

void CallTable::send_failure(const Entry& entry, proto::CallOutcome outcome, std::string_view reason) {
    auto back = entry.back.lock();
    if (!back || back->closed()) {
        ++counters_.caller_gone;
        return;
    }
    proto::Bytes frame;
    proto::append_failed_answer_frame(frame, entry.back_id, outcome, entry.what + ": " + std::string(reason));
    back->send(std::move(frame));
}

void CallTable::finish(std::uint64_t id, bool answered) {
    const auto entry = entries_.find(id);
    if (entry == entries_.end())
        return;
    deadlines_.erase({entry->second.deadline, id});
    if (auto port = entry->second.port.lock())
        --port->calls_outstanding;
    finished_[id] = Finished{answered, entry->second.out};
    entries_.erase(entry);
    finished_order_.push_back(id);
    if (finished_order_.size() > remembered_calls) {
        finished_.erase(finished_order_.front());
        finished_order_.pop_front();
    }
}

void CallTable::arm_timer() {
    if (deadlines_.empty())
        return;
    const auto earliest = deadlines_.begin()->first;
    if (timer_armed_ && timer_.expiry() <= earliest)
        return;
    timer_armed_ = true;
    timer_.expires_at(earliest);
    std::weak_ptr<CallTable> weak = weak_from_this();
    timer_.async_wait([weak](const boost::system::error_code& error) {
        if (error == asio::error::operation_aborted)
            return;  // re-armed earlier, or the table is going
        if (auto table = weak.lock()) {
            table->timer_armed_ = false;
            table->sweep();
        }
    });
}

void CallTable::sweep() {
    const auto now = Clock::now();
    while (!deadlines_.empty() && deadlines_.begin()->first <= now) {
        const auto [deadline, id] = *deadlines_.begin();
        (void)deadline;
        fail(id, proto::CallOutcome::timeout, "no answer within the caller's timeout");
        if (!deadlines_.empty() && deadlines_.begin()->second == id)
            deadlines_.erase(deadlines_.begin());  // an entry already gone
    }
    arm_timer();
}

void CallTable::add_stats(nlohmann::json& daemon) const {
    daemon["calls_outstanding"] = entries_.size();
    daemon["calls_started"] = counters_.started;
    daemon["calls_answered"] = counters_.answered;
    daemon["calls_refused"] = counters_.refused;
    daemon["calls_busy"] = counters_.busy;
    daemon["calls_timed_out"] = counters_.timed_out;
    daemon["calls_lost"] = counters_.lost;
    daemon["calls_caller_gone"] = counters_.caller_gone;
    daemon["calls_late_answers"] = counters_.late_answers;
    daemon["calls_duplicate_answers"] = counters_.duplicate_answers;
    daemon["calls_unknown_answers"] = counters_.unknown_answers;
}

}  // namespace plexus::daemon
