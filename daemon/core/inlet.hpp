#pragma once
// Threading: its port's thread (see port.hpp). Its one lock is its arbiter's (shared by the inlets
// of one port, whose monitors decide from several threads), held only while it admits a message.
// Its monitors may run elsewhere (a MessageFilter): their verdicts come back here, on the control
// thread, in order.

#include <cstdint>
#include <memory>
#include <string>

#include "../arbitration/arbiter.hpp"
#include "connection.hpp"
#include "message_filter.hpp"
#include "port.hpp"
#include "reassembly.hpp"

namespace plexus::daemon {

/// A connection as its destination port sees it, whether it comes from a port of this daemon or
/// from another daemon: where the recv-side monitors and the port's arbitration run, with the
/// counters `plexus stats` and `plexus events` show. Owned by the connection (local) or by the
/// link session (remote); the port only watches it.
class Inlet : public MessageSink, public FilterClient {
public:
    Inlet(std::shared_ptr<Port> port, std::string source, std::string carrier,
          std::shared_ptr<arbitration::Member> member)
        : port_(std::move(port)),
          source_(std::move(source)),
          carrier_(std::move(carrier)),
          member_(std::move(member)) {}
    /// The monitors go first: they take their events out of the port's container as they go.
    ~Inlet() override {
        if (monitors)
            monitors->close();
    }

    std::size_t shard() const override { return port_->shard(); }
    bool gone() const override { return port_->closed(); }
    bool full() const override { return room() == 0; }
    /// The port's room, less what is still in the monitors on its way there.
    std::size_t room() const override { return room_after(port_->room(), monitors.get()); }
    /// Without monitors: the arbitration (constraint, stimulation), then the port's reader queue.
    /// With monitors: to them first (accept, update, and the arbitration after them); what they
    /// pass reaches the port through filtered().
    void deliver(const Message& message) override;
    void filtered(std::vector<Filtered>& results) override;

    const std::shared_ptr<Port>& port() const { return port_; }
    const std::string& source() const { return source_; }
    const std::string& carrier() const { return carrier_; }
    /// `plexus param set` changed what its monitors run with (control/param.cpp).
    void set_carrier(std::string carrier) { carrier_ = std::move(carrier); }
    const arbitration::Member& member() const { return *member_; }

    /// The recv-side monitors; null when there are none. They decide with the arbitration.
    std::shared_ptr<MessageFilter> monitors;

    std::uint64_t received = 0;           ///< messages that arrived on this connection
    std::uint64_t dropped_by_accept = 0;  ///< dropped by a recv-side monitor
    std::uint64_t accepted = 0;           ///< passed the monitors, on to the arbitration
    std::uint64_t dropped_by_queue = 0;   ///< older messages a `latest` queue dropped to make room for these
    std::uint64_t delivered = 0;          ///< handed to the port's reader queue
    /// udp/mcast only: arrived while a strict queue was full (a datagram writer cannot be held back).
    std::uint64_t dropped_full = 0;
    /// udp/mcast only: the datagram stream feeding this inlet (lost, late), for stats.
    std::shared_ptr<const DatagramStream> datagrams;

private:
    /// A batch passes whole when nothing here looks at single messages; else record by record.
    void deliver_batch(const Message& batch);
    /// To the port's reader queue, counted; returns how many older messages a latest queue let go.
    std::uint64_t enqueue(const Message& message);

    std::shared_ptr<Port> port_;
    std::string source_;
    std::string carrier_;
    std::shared_ptr<arbitration::Member> member_;
};

}  // namespace plexus::daemon
