#pragma once
// Threading: the daemon's one thread.

#include <functional>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "arbitration/clock.hpp"
#include "core/inlet.hpp"
#include "plexus/proto/bytes.hpp"
#include "plexus/proto/carrier.hpp"

namespace plexus::daemon {

class MonitorWiring;

/// A connection into a port of this daemon, as `connect` (both ends here) or `attach` (the
/// source on another daemon) asks for it.
struct InletSpec {
    std::shared_ptr<Port> port;  ///< the destination
    std::string source;          ///< the sending port's name
    proto::Carrier carrier;      ///< its recv. clauses make the monitors and the arbitration
    std::string carrier_name;    ///< as stats and events show it
    bool strict = false;         ///< overlapping constraints refuse the connection, not warn
};

/// An inlet that has joined its port, and the arbitration warnings of its connection.
struct WiredInlet {
    std::shared_ptr<Inlet> inlet;
    nlohmann::json warnings;  ///< texts, one per pair of connections into the port that can both deliver
};

/// Gives a new inlet to what will feed it (a local connection, a link session) before it joins
/// its port; an Error stops the wiring.
using InletHandOver = std::function<proto::Status(const std::shared_ptr<Inlet>& inlet)>;

/// Wires a connection into `spec.port`: its place in the port's arbitration (configured from the
/// carrier), its recv-side monitors, and the check of that place against the port's other
/// connections (weights that make the stimulation system singular are an error; constraints
/// that overlap another connection's are warnings, errors with `strict`). Then `hand_over` (if
/// any) gives the inlet to what feeds it and, if that succeeds, the inlet joins the port: it is
/// listed in `port->inbound` and its member joins the arbiter. The first step that fails ends
/// it with its Error, and the inlet has not joined.
proto::Result<WiredInlet> wire_inlet(MonitorWiring& scripts, const arbitration::Clock& clock,
                                     const InletSpec& spec, const InletHandOver& hand_over = {});

}  // namespace plexus::daemon
