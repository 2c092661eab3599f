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
    if (!member_->trivial() || port_->queue().policy() != QueuePolicy::strict) {
        // Arbitration and latest queues decide message by message.
        for_each_record(batch, [this](const Message& single) { deliver(single); });
        return;
    }
    if (chain) {
        deliver_batch_through_chain(batch);
        return;
    }
    received += batch.count();
    accepted += batch.count();
    delivered += batch.count();
    port_->deliver(batch);
}

void Inlet::deliver_batch_through_chain(const Message& batch) {
    // The monitors see every record on its own; the records they pass unchanged, one after the
    // other, go on together as a smaller batch (the bytes of a run of records are contiguous), so
    // that a filter that passes most messages does not cost a queue entry and a frame per message.
    const std::uint8_t* run_begin = nullptr;
    const std::uint8_t* run_end = nullptr;
    std::uint32_t run_count = 0;
    auto deliver_passed = [this](const Message& passed) {
        delivered += passed.count();
        port_->deliver(passed);
    };
    auto end_run = [&] {
        if (run_count > 0)
            deliver_passed(Message{batch.storage, {run_begin, run_end}, 0, run_count});
        run_count = 0;
    };
    proto::BatchRecords records(batch.record, batch.batch);
    for (;;) {
        const std::uint8_t* entry_begin = records.rest().data();
        const auto record = records.next();
        if (!record)
            break;
        ++received;
        Message passed{batch.storage, *record, 0, 0};
        if (!chain->process(passed)) {
            ++dropped_by_accept;
            end_run();
            continue;
        }
        ++accepted;
        if (passed.record.data() != record->data() || passed.record.size() != record->size()) {
            end_run();  // rewritten: a message of its own
            deliver_passed(passed);
            continue;
        }
        if (run_count == 0)
            run_begin = entry_begin;
        run_end = records.rest().data();
        ++run_count;
    }
    end_run();
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
