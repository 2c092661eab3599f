#include "inlet.hpp"

#include <mutex>

#include "batch.hpp"
#include "call_ticket.hpp"

namespace plexus::daemon {

namespace {
TapDecision::Outcome outcome_of(arbitration::Arbiter::Verdict verdict) {
    switch (verdict) {
        case arbitration::Arbiter::Verdict::constraint:
            return TapDecision::Outcome::constraint;
        case arbitration::Arbiter::Verdict::priority:
            return TapDecision::Outcome::priority;
        case arbitration::Arbiter::Verdict::auxiliary:
            return TapDecision::Outcome::auxiliary;
        case arbitration::Arbiter::Verdict::deliver:
            break;
    }
    return TapDecision::Outcome::delivered;
}
}  // namespace

void Inlet::deliver(const Message& message) {
    if (message.batch != 0) {
        deliver_batch(message);
        return;
    }
    ++received;
    PortTap* tap = port_->tap.get();
    if (tap)
        tap->arrived(*this, message);
    if (monitors) {
        monitors->submit(message);
        return;
    }
    ++accepted;
    TapDecision decision;
    if (!member_->trivial()) {
        auto verdict = arbitration::Arbiter::Verdict::deliver;
        {
            // The arbiter is shared with the monitors of the port's other connections, on their
            // threads. The tap is told after the lock is let go: it may take it itself.
            auto& arbiter = member_->arbiter();
            std::lock_guard lock(arbiter.mutex());
            const double now = arbiter.now();
            verdict = arbiter.admit(*member_, now);
            decision.monitor_time = decision.decision_time = now;
        }
        if (verdict != arbitration::Arbiter::Verdict::deliver) {
            // counted by the arbiter (constraint, priority) or an auxiliary connection
            if (message.call) {
                message.call->set_drop_reason(std::string("refused by the arbitration of ") + port_->name() +
                                              " (" + arbitration::Arbiter::verdict_name(verdict) + ")");
            }
            if (tap) {
                decision.outcome = outcome_of(verdict);
                tap->decided(*this, message, decision);
            }
            return;
        }
    } else if (tap) {
        decision.monitor_time = decision.decision_time = member_->arbiter().now();
    }
    decision.queue_dropped = enqueue(message);
    if (tap)
        tap->decided(*this, message, decision);
}

void Inlet::filtered(std::vector<Filtered>& results) {
    PortTap* tap = port_->tap.get();
    for (auto& result : results) {
        TapDecision decision{TapDecision::Outcome::delivered, result.monitor_time, result.decision_time};
        switch (result.verdict) {
            case FilterVerdict::dropped:
                ++dropped_by_accept;
                decision.outcome = TapDecision::Outcome::accept;
                break;
            case FilterVerdict::refused:
                ++accepted;  // the arbiter counted why
                decision.outcome = outcome_of(result.arbitration);
                break;
            case FilterVerdict::pass:
                accepted += result.message.count();
                decision.queue_dropped = enqueue(result.message);
                break;
        }
        if (tap)
            tap->decided(*this, result.message, decision);
    }
}

std::uint64_t Inlet::enqueue(const Message& message) {
    const auto dropped_before = port_->queue().dropped();
    delivered += message.count();
    port_->deliver(message);
    const std::uint64_t dropped = port_->queue().dropped() - dropped_before;
    dropped_by_queue += dropped;
    return dropped;
}

void Inlet::deliver_batch(const Message& batch) {
    if (!member_->trivial() || port_->queue().policy() != QueuePolicy::strict) {
        // Arbitration and latest queues decide message by message.
        for_each_record(batch, [this](const Message& single) { deliver(single); });
        return;
    }
    received += batch.count();
    // A tap takes the batch whole (it splits it on its own thread), so that recording a port
    // keeps the batched path.
    PortTap* tap = port_->tap.get();
    if (tap)
        tap->arrived(*this, batch);
    if (monitors) {
        monitors->submit(batch);  // record by record there
        return;
    }
    accepted += batch.count();
    TapDecision decision;
    if (tap)
        decision.monitor_time = decision.decision_time = member_->arbiter().now();
    decision.queue_dropped = enqueue(batch);
    if (tap)
        tap->decided(*this, batch, decision);
}

}  // namespace plexus::daemon
