#pragma once
// Threading: deliver(), room() and full() on the source port's thread (or the control thread,
// which runs alone: handler_gate.hpp); arrive() and refresh_room() on the sink's. What both read
// is atomic or goes through the sink's Shard mail.

#include <atomic>
#include <cstddef>
#include <deque>
#include <memory>

#include "../core/connection.hpp"

namespace plexus::daemon {

class Shard;

/// The way from a port on one of the daemon's threads to a sink on another (`--threads`): the
/// messages go as mail to the sink's thread, in order, and are delivered there. A connection keeps
/// its order: its messages all take the same mail, whichever thread writes them.
///
/// Back-pressure: the source may have the sink's room on its way, as the sink's thread last
/// published it, plus a little more (`slack_messages`, `slack_bytes`): what arrives while the sink
/// is full waits here, on the sink's thread, and goes in as the sink's reader makes room. Without
/// that slack a strict queue of 4 let a writer through four messages per round trip between the
/// threads (two wake-ups), a few thousand a second on a busy machine; with it, the sink's depth
/// still never passes its capacity, as with a writer on its own thread, whose messages wait in
/// its socket instead.
///
/// A message is copied when it crosses: a chunk read from a socket or a ring is reused by its
/// reader once nothing refers to it, and that check is not one another thread can take part in.
class ShardCrossing final : public MessageSink, public std::enable_shared_from_this<ShardCrossing> {
public:
    /// What may wait on the sink's thread beyond the sink's room, in messages and in bytes.
    static constexpr std::size_t slack_messages = 128;
    static constexpr std::size_t slack_bytes = 128 * 1024;

    ShardCrossing(std::shared_ptr<Shard> source, std::shared_ptr<Shard> target,
                  std::shared_ptr<MessageSink> sink);

    bool full() const override { return room() == 0; }
    std::size_t room() const override;
    void deliver(const Message& message) override;
    void close_after_flush() override;
    void report_stats(nlohmann::json& entry) const override { sink_->report_stats(entry); }
    std::shared_ptr<MessageFilter> shared_send_stage() const override { return sink_->shared_send_stage(); }
    std::size_t shard() const override { return sink_->shard(); }
    bool gone() const override { return sink_->gone(); }

    // On the sink's thread:
    /// A message sent across arrived: to the sink, or held while the sink is full.
    void arrive(const Message& message);
    /// The connection is going: the sink sends what it holds and lets go (after what waits here).
    void arrive_close();
    /// Room may have appeared in the sink: what waits here goes in while it fits (all of it is
    /// dropped if the sink is gone). True while some still waits.
    bool release_held();
    /// Publishes the sink's room; returns what the source may send now (0: it waits; any when the
    /// sink is gone).
    std::size_t refresh_room();
    /// The source's writers held back may try again.
    void wake_source();

private:
    /// What the source may send with `seen` room in the sink and `flight` messages of `bytes` on
    /// their way or waiting here.
    static std::size_t room_for(std::size_t seen, std::size_t flight, std::size_t bytes);
    /// Asks the sink's thread to publish the room and wake the source when there is some (once
    /// until it does).
    void ask_for_room() const;
    /// On the sink's thread: to the sink, no longer counted on its way.
    void pass(const Message& message);
    /// No longer counted on its way (passed, or let go with a sink that is gone).
    void forget(const Message& message);

    std::shared_ptr<Shard> source_;
    std::shared_ptr<Shard> target_;
    std::shared_ptr<MessageSink> sink_;
    std::atomic<std::size_t> room_seen_;        ///< the sink's room, as its thread last saw it
    std::atomic<std::size_t> in_flight_{0};     ///< messages sent and not yet in the sink
    std::atomic<std::size_t> flight_bytes_{0};  ///< their bytes
    mutable std::atomic<bool> asking_{false};   ///< waiting for room (Shard::want_room)
    // The sink's thread's:
    std::deque<Message> held_;  ///< arrived while the sink was full, in order
    bool close_held_ = false;   ///< the close arrived behind held messages
};

}  // namespace plexus::daemon
