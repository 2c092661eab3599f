#pragma once
// What a carrier string says about arbitration: the `constraint.` and `aux` keys of a
// `recv.portmonitor` clause, and the `recv.priority` clause.

#include <optional>

#include "arbiter.hpp"
#include "plexus/proto/carrier.hpp"

namespace plexus::daemon::arbitration {

/// Sets the member's constraint, aux flag and stimulation from the carrier. Errors name the bad
/// part: a constraint that does not parse (with its position), arbitration keys on the send
/// side, two constraints or two priority clauses, an unknown or malformed priority key.
proto::Status configure_member(Member& member, const proto::Carrier& carrier);

/// The `constraint.` of a send.portmonitor clause: a route constraint, evaluated over the events
/// of the *source* port (set by the monitors of connections into it). The connection carries the
/// source's messages and calls only while it holds; among a port's connections to servers, a call
/// goes to the one whose route constraint holds (request/reply). None when the carrier has none.
proto::Result<std::optional<Constraint>> route_constraint(const proto::Carrier& carrier);

/// True for a portmonitor clause with no script, only arbitration keys (`constraint.`, `aux`).
bool arbitration_only(const proto::Clause& clause);

}  // namespace plexus::daemon::arbitration
