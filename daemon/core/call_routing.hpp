#pragma once
// Threading: the daemon's thread (takes the source port's arbiter lock to read its events).

#include <string>
#include <variant>

#include "connection.hpp"
#include "port.hpp"

namespace plexus::daemon {

/// Whether `connection`'s route constraint holds now over the events of `source` (its event
/// container, fed by the monitors of the connections into it); true for a connection without one.
bool route_holds(const Port& source, const Connection& connection);

/// The connection a call written into `source` goes to: among the connections out of it that can
/// carry calls, the first whose route constraint holds now (connections are kept in the order made,
/// within their qos.prio: ties go to the earliest, as in arbitration). Otherwise why there is none,
/// for a person: each candidate and what it waits for.
std::variant<Connection*, std::string> choose_server(const Port& source);

/// Sends a call along `connection` (through its send-side monitors, if any), counted as sent.
void send_call(Connection& connection, const Message& call);

}  // namespace plexus::daemon
