#include "shard_crossing.hpp"

#include <cstring>

#include "shards.hpp"
#include "shm_region.hpp"

namespace plexus::daemon {

namespace {
bool same_unit(const Message& a, const Message& b) {
    return a.storage && a.storage == b.storage && a.record.data() == b.record.data() &&
           a.record.size() == b.record.size();
}

/// The message with a record of its own (see ShardCrossing): the chunk it was read into stays
/// with the thread that read it. The same unit handed to several connections (a port's
/// connections one after the other) is copied once, and stays one unit where it arrives: an mcast
/// sender sends a unit once for all the connections it serves.
Message own_copy(const Message& message) {
    thread_local Message last_original;  // held: its chunk cannot be reused while it is compared
    thread_local Message last_copy;
    if (same_unit(message, last_original))
        return last_copy;
    Message copy = message;
    if (message.shm) {
        copy = copy_out_of_shm(message);  // sessions do not lend across threads; safe if one did
    } else {
        auto chunk = std::make_shared<Chunk>(message.record.size());
        std::memcpy(chunk->data(), message.record.data(), message.record.size());
        copy.record = proto::ByteView(chunk->data(), message.record.size());
        copy.storage = std::move(chunk);
    }
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

std::size_t ShardCrossing::room() const {
    const std::size_t seen = room_seen_.load(std::memory_order_relaxed);
    const std::size_t flight = in_flight_.load(std::memory_order_relaxed);
    const std::size_t room = seen > flight ? seen - flight : 0;
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
    target_->send(shared_from_this(), own_copy(message), false);
    // This one filled the room: the writer holds back next, so ask now to be told when it may go on
    // (a batch cut to fit is held back without looking at room() again).
    if (flight >= room_seen_.load(std::memory_order_relaxed))
        ask_for_room();
}

void ShardCrossing::close_after_flush() {
    target_->send(shared_from_this(), Message{}, true);
}

void ShardCrossing::arrive(const Message& message) {
    sink_->deliver(message);
    room_seen_.store(sink_->room(), std::memory_order_relaxed);
    in_flight_.fetch_sub(message.count(), std::memory_order_relaxed);
}

std::size_t ShardCrossing::refresh_room() {
    const std::size_t room = sink_->room();
    room_seen_.store(room, std::memory_order_relaxed);
    if (room > in_flight_.load(std::memory_order_relaxed))
        asking_.store(false, std::memory_order_release);
    return room > in_flight_.load(std::memory_order_relaxed) ? room : 0;
}

void ShardCrossing::wake_source() {
    source_->poke();
}

}  // namespace plexus::daemon
