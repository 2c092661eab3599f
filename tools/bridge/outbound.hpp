#pragma once
// The Plexus side of a mapping out of Plexus: an input port of the bridge whose messages a callback
// sends to the other system. A message that one of this bridge's inbound ports of the same topic
// wrote (a connection led it back) is not sent again: a bridge never re-publishes what it injected
// where it came from. It is counted as "own_message". One from an inbound port of another topic is
// a relay, and goes out.
#include <functional>
#include <memory>
#include <set>
#include <string>

#include <plexus/client.hpp>

#include "port_counters.hpp"

namespace plexus::bridge {

class Outbound {
public:
    /// Passes one message on to the other system, counting it passed or dropped (with a reason:
    /// "not_converted", "not_delivered", ...). An exception it throws counts as "not_delivered".
    using Send = std::function<void(const Received&, PortCounters&)>;
    /// Opens `port` (a strict queue of `capacity`, 0: the daemon's default). `own_ports` are the
    /// bridge's inbound ports fed from the topic this port publishes to (a message from one of them
    /// would go back where it came from); `peer` names the other side in logs ("rt/cmd_vel").
    Outbound(Client& client, const std::string& port, std::string peer, std::set<std::string> own_ports,
             std::size_t capacity = 0);

    /// Starts reading: `send` runs on the outbound's own thread, one message at a time.
    void start(Send send);
    /// Stops reading (waits for the message being sent).
    void stop();

    Port& port() { return port_; }
    PortCounters& counters() { return counters_; }

private:
    Port port_;
    PortCounters counters_;
    std::set<std::string> own_ports_;
    std::unique_ptr<Subscription> subscription_;
};

/// Options for a bridge's inbound ports: strict, so that a slow reader slows the bridge rather than
/// losing data silently.
PortOptions inbound_port_options();

}  // namespace plexus::bridge
