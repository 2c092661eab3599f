#include "inlet.hpp"

#include <mutex>

#include "batch.hpp"

namespace plexus::daemon {

void Inlet::deliver(const Message& message) {
    if (message.batch != 0) {
        deliver_batch(message);
        return;
    }
    ++received;
    if (monitors) {
        monitors->submit(message);
        return;
    }
    ++accepted;
    if (!member_->trivial()) {
        // The arbiter is shared with the monitors of the port's other connections, on their threads.
        std::lock_guard lock(member_->arbiter().mutex());
        if (member_->arbiter().admit(*member_) != arbitration::Arbiter::Verdict::deliver)
            return;  // counted by the arbiter (constraint, priority) or an auxiliary connection
    }
    enqueue(message);
}

void Inlet::filtered(std::vector<Filtered>& results) {
    for (auto& result : results) {
        switch (result.verdict) {
            case FilterVerdict::dropped:
                ++dropped_by_accept;
                break;
            case FilterVerdict::refused:
                ++accepted;  // the arbiter counted why
                break;
            case FilterVerdict::pass:
                accepted += result.message.count();
                enqueue(result.message);
                break;
        }
    }
}

void Inlet::enqueue(const Message& message) {
    const auto dropped_before = port_->queue().dropped();
    delivered += message.count();
    port_->deliver(message);
    dropped_by_queue += port_->queue().dropped() - dropped_before;
}

void Inlet::deliver_batch(const Message& batch) {
    if (!member_->trivial() || port_->queue().policy() != QueuePolicy::strict) {
        // Arbitration and latest queues decide message by message.
        for_each_record(batch, [this](const Message& single) { deliver(single); });
        return;
    }
    received += batch.count();
    if (monitors) {
        monitors->submit(batch);  // record by record there
        return;
    }
    accepted += batch.count();
    enqueue(batch);
}

}  // namespace plexus::daemon
