#include "inlet.hpp"

#include <optional>

#include "../monitor/chain.hpp"
#include "batch.hpp"

namespace plexus::daemon {

void Inlet::deliver(const Message& message) {
    if (message.batch != 0) {
        deliver_batch(message);
        return;
    }
    ++received;
    std::optional<Message> rewritten;  // only with monitors: without, no copy of the message
    if (chain) {
        rewritten = message;
        if (!chain->process(*rewritten)) {
            ++dropped_by_accept;
            return;
        }
    }
    const Message& passed = rewritten ? *rewritten : message;
    ++accepted;
    if (!member_->trivial() && member_->arbiter().admit(*member_) != arbitration::Arbiter::Verdict::deliver)
        return;  // counted by the arbiter (constraint, priority) or an auxiliary connection
    const auto dropped_before = port_->queue().dropped();
    ++delivered;
    port_->deliver(passed);
    dropped_by_queue += port_->queue().dropped() - dropped_before;
}

void Inlet::deliver_batch(const Message& batch) {
    if (chain || !member_->trivial() || port_->queue().policy() != QueuePolicy::strict) {
        // Monitors, arbitration and latest queues decide message by message.
        for_each_record(batch, [this](const Message& single) { deliver(single); });
        return;
    }
    received += batch.count();
    accepted += batch.count();
    delivered += batch.count();
    port_->deliver(batch);
}

std::uint64_t Inlet::script_errors() const {
    std::uint64_t errors = 0;
    if (chain) {
        for (const auto& monitor : chain->monitors)
            errors += monitor->counters().errors;
    }
    return errors;
}

}  // namespace plexus::daemon
