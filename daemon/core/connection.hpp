#pragma once
// Threading: its source port's thread (with `--threads`, a data thread; the control thread may
// use it too, never at the same time: net/handler_gate.hpp); no locking. A sink on another thread
// is reached through Connection::crossing.

#include <cstdint>
#include <memory>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "../arbitration/constraint.hpp"
#include "message.hpp"
#include "message_filter.hpp"

namespace plexus::daemon {

/// The room of a sink that is never full (a datagram sender): large enough never to cut a batch,
/// small enough that sums of it cannot overflow.
inline constexpr std::size_t never_full_room = std::size_t{1} << 30;

/// Where a connection delivers: a port of this daemon, or a link to another daemon.
class MessageSink {
public:
    virtual ~MessageSink() = default;
    /// True while a writer must wait before sending more (strict back-pressure).
    virtual bool full() const = 0;
    /// How many more messages it takes before it is full (a batch is cut to fit).
    virtual std::size_t room() const = 0;
    virtual void deliver(const Message& message) = 0;
    /// The connection is going away: send what is queued, then let go.
    virtual void close_after_flush() {}
    /// Adds what this sink counts itself to its connection's entry in `plexus stats` (a tcp link's
    /// queue, a datagram sender's counters). The views ask the sink rather than cast it to each
    /// carrier's type, so that a new carrier's sending end reports itself. Nothing by default.
    virtual void report_stats(nlohmann::json& entry) const { (void)entry; }
    /// The send-side monitors when the sink runs them itself, for every connection it serves (mcast:
    /// once per source port); null when each connection runs its own (Connection::send_monitors).
    virtual std::shared_ptr<MessageFilter> shared_send_stage() const { return nullptr; }
    /// The daemon's thread this sink is used on (`--threads`): a port's is its session's data
    /// thread; 0, the control thread, for everything else (links, datagram senders).
    virtual std::size_t shard() const { return 0; }
    /// True once nothing will ever be taken from it again (its port closed): what waits to go in
    /// may be let go.
    virtual bool gone() const { return false; }
};

/// A directed connection out of a port of this daemon.
struct Connection final : FilterClient {
    ~Connection() override {
        if (send_monitors)
            send_monitors->close();
    }

    std::string source;
    std::string destination;
    std::string carrier;  ///< canonical carrier text
    bool remote = false;  ///< true when the destination lives on another daemon (or the carrier forces tcp)
    bool persistent = false;  ///< made with --persist: the name server keeps it across restarts
    int priority = 0;         ///< qos.prio: its port hands each message to higher ones first (Router::add)
    std::shared_ptr<MessageSink> sink;
    /// Set when the sink lives on another of the daemon's data threads than the source port
    /// (`--threads`): the way there (net/shard_crossing.hpp). Null otherwise.
    std::shared_ptr<MessageSink> crossing;
    /// Where the source's messages go: the crossing when there is one, else the sink itself.
    MessageSink& way_out() const { return crossing ? *crossing : *sink; }
    /// The send-side monitors, before the sink; null when there are none (or when an mcast sender
    /// runs them for all the port's mcast connections at once).
    std::shared_ptr<MessageFilter> send_monitors;
    /// A send.portmonitor clause's `constraint.`: over the source port's events, whether this
    /// connection carries the source's messages now, and which server a call goes to.
    std::optional<arbitration::Constraint> route_constraint;
    std::uint64_t sent = 0;                ///< messages written into the source
    std::uint64_t dropped_by_monitor = 0;  ///< dropped by a send-side monitor
    std::uint64_t dropped_by_route = 0;    ///< not taken: its route constraint was false
    std::uint64_t calls = 0;               ///< calls sent to its server
    /// True for a carrier that can take calls: requests need their answer back on the same path,
    /// which a datagram carrier (udp, mcast) has not.
    bool carries_calls() const { return carrier.rfind("udp", 0) != 0 && carrier.rfind("mcast", 0) != 0; }

    /// How many more messages the source may write into this connection.
    std::size_t room() const { return room_after(way_out().room(), send_monitors.get()); }
    /// The connection is going: the sink sends what it holds, then lets go; messages still in the
    /// send-side monitors reach it first.
    void close_after_flush() {
        if (send_monitors && send_monitors->in_flight() > 0)
            closing_ = true;  // filtered() closes the sink after the last of them
        else
            way_out().close_after_flush();
    }
    /// What the send-side monitors passed goes on to the sink, in order.
    void filtered(std::vector<Filtered>& results) override {
        for (auto& result : results) {
            if (result.verdict == FilterVerdict::pass)
                way_out().deliver(result.message);
            else
                dropped_by_monitor += result.message.count();
        }
        if (closing_ && send_monitors->in_flight() == 0) {
            closing_ = false;
            way_out().close_after_flush();
        }
    }

private:
    bool closing_ = false;
};

}  // namespace plexus::daemon
