#pragma once
// Threading: deliver(), room() and full() on the source port's thread (or the control thread,
// which runs alone: handler_gate.hpp); arrive() and refresh_room() on the sink's. What both read
// is atomic or goes through the sink's Shard mail.

#include <atomic>
#include <cstddef>
#include <memory>

#include "../core/connection.hpp"

namespace plexus::daemon {

class Shard;

/// The way from a port on one of the daemon's threads to a sink on another (`--threads`): the
/// messages go as mail to the sink's thread, in order, and are delivered there; the source learns
/// the sink's room from what the sink's thread last published, less what is still on its way. A
/// connection keeps its order: its messages all take the same mail, whichever thread writes them.
///
/// A message is copied when it crosses: a chunk read from a socket or a ring is reused by its
/// reader once nothing refers to it, and that check is not one another thread can take part in.
class ShardCrossing final : public MessageSink, public std::enable_shared_from_this<ShardCrossing> {
public:
    ShardCrossing(std::shared_ptr<Shard> source, std::shared_ptr<Shard> target,
                  std::shared_ptr<MessageSink> sink);

    bool full() const override { return room() == 0; }
    std::size_t room() const override;
    void deliver(const Message& message) override;
    void close_after_flush() override;
    void report_stats(nlohmann::json& entry) const override { sink_->report_stats(entry); }
    std::shared_ptr<MessageFilter> shared_send_stage() const override { return sink_->shared_send_stage(); }
    std::size_t shard() const override { return sink_->shard(); }

    // On the sink's thread:
    /// A message sent across arrived: to the sink.
    void arrive(const Message& message);
    /// The connection is going: the sink sends what it holds and lets go.
    void arrive_close() { sink_->close_after_flush(); }
    /// Publishes the sink's room; returns it.
    std::size_t refresh_room();
    /// The source's writers held back may try again.
    void wake_source();

private:
    /// Asks the sink's thread to publish the room and wake the source when there is some (once
    /// until it does).
    void ask_for_room() const;

    std::shared_ptr<Shard> source_;
    std::shared_ptr<Shard> target_;
    std::shared_ptr<MessageSink> sink_;
    std::atomic<std::size_t> room_seen_;       ///< the sink's room, as its thread last saw it
    std::atomic<std::size_t> in_flight_{0};    ///< messages sent and not yet delivered
    mutable std::atomic<bool> asking_{false};  ///< waiting for room (Shard::want_room)
};

}  // namespace plexus::daemon
