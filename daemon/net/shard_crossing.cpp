#include "shard_crossing.hpp"

#include <cstring>
#include <limits>

#include "../core/batch.hpp"
#include "shards.hpp"

namespace plexus::daemon {

namespace {
bool same_unit(const Message& a, const Message& b) {
    return a.storage && a.storage == b.storage && a.record.data() == b.record.data() &&
           a.record.size() == b.record.size();
}

/// The message with a record of its own (see ShardCrossing): the chunk it was read into stays
/// with the thread that read it. A payload lent in shared memory stays there: only its place is
/// copied, and the slot is held from the reader's thread (shm_region.hpp). The same unit handed
/// to several connections (a port's connections one after the other) is copied once, and stays
/// one unit where it arrives: an mcast sender sends a unit once for all the connections it serves.
Message own_copy(const Message& message) {
    thread_local Message last_original;  // held: its chunk cannot be reused while it is compared
    thread_local Message last_copy;
    if (same_unit(message, last_original))
        return last_copy;
    Message copy = message;
    auto chunk = std::make_shared<Chunk>(message.record.size());
    std::memcpy(chunk->data(), message.record.data(), message.record.size());
    copy.record = proto::ByteView(chunk->data(), message.record.size());
    copy.storage = std::move(chunk);
    if (!message.shm && !message.call) {  // a call's ticket must end with its last real copy
        last_original = message;
        last_copy = copy;
    }
    return copy;
}
}  // namespace

ShardCrossing::ShardCrossing(std::shared_ptr<Shard> source, std::shared_ptr<Shard> target,
                             std::shared_ptr<MessageSink> sink)
    : source_(std::move(source)),
      target_(std::move(target)),
      sink_(std::move(sink)),
      room_seen_(sink_->room()) {}

std::size_t ShardCrossing::room_for(std::size_t seen, std::size_t flight, std::size_t bytes) {
    // Within the bytes, the slack counts whatever the room: a writer told less would cut its batch,
    // hold back, and wait for a wake-up that nobody owes it (deliver() asks only at 0).
    // A sink that is never full (a latest queue) has room without end: no sum past the largest.
    const std::size_t slack = bytes < slack_bytes ? slack_messages : 0;
    const std::size_t allowed = seen > std::numeric_limits<std::size_t>::max() - slack ? seen : seen + slack;
    return flight < allowed ? allowed - flight : 0;
}

std::size_t ShardCrossing::room() const {
    const std::size_t room =
        room_for(room_seen_.load(std::memory_order_relaxed), in_flight_.load(std::memory_order_relaxed),
                 flight_bytes_.load(std::memory_order_relaxed));
    if (room == 0)
        ask_for_room();
    return room;
}

void ShardCrossing::ask_for_room() const {
    if (!asking_.exchange(true, std::memory_order_acq_rel))
        target_->want_room(std::const_pointer_cast<ShardCrossing>(shared_from_this()));
}

void ShardCrossing::deliver(const Message& message) {
    const std::size_t flight =
        in_flight_.fetch_add(message.count(), std::memory_order_relaxed) + message.count();
    const std::size_t bytes =
        flight_bytes_.fetch_add(message.record.size(), std::memory_order_relaxed) + message.record.size();
    target_->send(shared_from_this(), own_copy(message), false);
    // This one used the last room: the writer holds back next, so ask now to be told when it may
    // go on (a batch cut to fit is held back without looking at room() again).
    if (room_for(room_seen_.load(std::memory_order_relaxed), flight, bytes) == 0)
        ask_for_room();
}

void ShardCrossing::close_after_flush() {
    target_->send(shared_from_this(), Message{}, true);
}

void ShardCrossing::arrive(const Message& message) {
    if (sink_->gone()) {
        forget(message);  // as the port's own queue went with it
        return;
    }
    if (held_.empty() && message.count() <= sink_->room()) {
        pass(message);
        return;
    }
    if (held_.empty())
        target_->hold(shared_from_this());
    held_.push_back(message);
    release_held();  // what fits goes in now
}

void ShardCrossing::arrive_close() {
    if (held_.empty())
        sink_->close_after_flush();
    else
        close_held_ = true;
}

void ShardCrossing::pass(const Message& message) {
    sink_->deliver(message);
    room_seen_.store(sink_->room(), std::memory_order_relaxed);
    forget(message);
}

void ShardCrossing::forget(const Message& message) {
    in_flight_.fetch_sub(message.count(), std::memory_order_relaxed);
    flight_bytes_.fetch_sub(message.record.size(), std::memory_order_relaxed);
}

bool ShardCrossing::release_held() {
    const bool gone = sink_->gone();  // its reader's queue went, and with it what waits for it
    while (!held_.empty()) {
        Message& head = held_.front();
        if (gone) {
            forget(head);
            held_.pop_front();
            continue;
        }
        const std::size_t room = sink_->room();
        if (room == 0)
            break;
        if (head.count() <= room) {
            pass(head);
            held_.pop_front();
        } else {
            // Only a batch is larger than the room: its head goes in, the rest waits, so that a
            // strict queue's bound holds for batches too (as Session::deliver_within does).
            const auto fits = static_cast<std::uint32_t>(room);
            pass(first_records(head, fits));
            head = without_first_records(head, fits);
        }
    }
    if (!held_.empty()) {
        room_seen_.store(0, std::memory_order_relaxed);
        return true;
    }
    if (close_held_) {
        close_held_ = false;
        sink_->close_after_flush();
    }
    return false;
}

std::size_t ShardCrossing::refresh_room() {
    if (sink_->gone()) {
        // Nothing will make room there: the source hears at once (its connection went with the
        // port), and the shard lets go of this crossing, and with it the sink and what it holds.
        asking_.store(false, std::memory_order_release);
        return never_full_room;
    }
    const std::size_t room = held_.empty() ? sink_->room() : 0;
    room_seen_.store(room, std::memory_order_relaxed);
    const std::size_t allowed = room_for(room, in_flight_.load(std::memory_order_relaxed),
                                         flight_bytes_.load(std::memory_order_relaxed));
    if (allowed > 0)
        asking_.store(false, std::memory_order_release);
    return allowed;
}

void ShardCrossing::wake_source() {
    source_->poke();
}

}  // namespace plexus::daemon
