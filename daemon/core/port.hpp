#pragma once
// Threading: the thread of the session that opened it (`--threads`: a data thread, which the
// control thread never runs beside: net/handler_gate.hpp); no locking.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "../arbitration/arbiter.hpp"
#include "connection.hpp"
#include "message_sampler.hpp"
#include "port_tap.hpp"
#include "reader_queue.hpp"

namespace plexus::daemon {

class Inlet;

/// A port hosted by this daemon for one client session. The client writes into it (the messages go
/// out along its connections) and reads from it (what its inbound connections deliver).
class Port : public MessageSink {
public:
    Port(std::string name, std::uint64_t owner, QueuePolicy policy, std::size_t capacity,
         std::size_t max_bytes = ReaderQueue::default_max_bytes)
        : name_(std::move(name)), owner_(owner), queue_(policy, capacity, max_bytes) {}

    const std::string& name() const { return name_; }
    std::uint64_t owner() const { return owner_; }
    ReaderQueue& queue() { return queue_; }
    const ReaderQueue& queue() const { return queue_; }
    bool closed() const { return closed_; }

    /// The daemon's thread it lives on: its session's (`--threads`; 0 for the control thread).
    std::size_t shard() const override { return shard_; }
    void set_shard(std::size_t shard) { shard_ = shard; }

    bool full() const override { return queue_.full(); }
    std::size_t room() const override { return queue_.room(); }
    void deliver(const Message& message) override;

    /// Called whenever the queue goes from empty to not empty (wakes the owner's writer).
    std::function<void()> on_readable;
    /// Runs `callback` once when the port closes (drops inbound links, wakes waiters), unless
    /// `owner` is gone by then. Callbacks of owners already gone are dropped here, so that a port
    /// that lives long while links come and go does not collect them.
    void on_close(std::weak_ptr<void> owner, std::function<void()> callback);

    std::vector<std::shared_ptr<Connection>> outgoing;
    /// The connections into this port (owned by their connections or link sessions).
    std::vector<std::weak_ptr<Inlet>> inbound;
    /// The arbitration of what comes in: event container, constraints, stimulation. Made with the
    /// first connection into the port.
    std::shared_ptr<arbitration::Arbiter> arbiter;

    /// Its client answers calls on it (opened to serve). A call into any other port goes on along
    /// its connections (route_call), or is refused when there are none.
    bool served = false;
    /// Calls through this port not yet answered or failed (as caller, or as the server's port).
    std::uint64_t calls_outstanding = 0;
    std::uint64_t calls_refused = 0;  ///< calls into it while it was not served

    /// Counters its client keeps about it and reports (`report`): a bridge's conversion and
    /// delivery failures. An empty map until the client reports.
    nlohmann::json reported = nlohmann::json::object();

    std::uint64_t written = 0;      ///< messages its client wrote into it
    std::uint64_t unconnected = 0;  ///< of those, written while no connection went out of it
    std::uint64_t received = 0;     ///< messages that arrived through connections
    std::uint64_t delivered = 0;    ///< messages handed to its client's socket
    /// Set while someone watches the port's last messages (the web endpoint); null otherwise.
    std::unique_ptr<MessageSampler> sampler;
    /// Set while someone records what reaches the port and what became of it; null otherwise.
    /// Whoever sets it also sets the arbiter watched (Arbiter::set_watched).
    std::shared_ptr<PortTap> tap;

    void mark_closed();
    /// A call reached this port, which nobody serves: passed on to the connection its arbitration
    /// selects (call_routing.hpp), or dropped with the reason.
    void route_call(const Message& message);

    /// A connection into the port asked for `qos.prio.N`: while `connection` lives, the port's
    /// reader is served at N at least on its client's socket (Outbox's strict priority).
    void ask_priority(std::weak_ptr<void> connection, int priority);
    /// The highest qos.prio of the live connections into it; 0 when none asked.
    int priority() const;

private:
    std::string name_;
    std::uint64_t owner_;
    ReaderQueue queue_;
    bool closed_ = false;
    std::size_t shard_ = 0;
    std::vector<std::pair<std::weak_ptr<void>, std::function<void()>>> on_close_;
    std::vector<std::pair<std::weak_ptr<void>, int>> priorities_;
};

}  // namespace plexus::daemon
