#pragma once
// The operations of the control protocol (PROTOCOL.md, "Control operations"), spelled once: those
// a daemon answers (its clients', the CLI's and other daemons' requests) and those the name server
// answers. A request body is a CBOR map whose "op" is one of these names; everything else in it is
// the operation's fields.

#include <optional>
#include <string_view>

#include <nlohmann/json.hpp>

namespace plexus::proto {

enum class Op {
    // A daemon's.
    open,           ///< a client opens a port
    close,          ///< a client closes one
    shm,            ///< a client asks for (or releases) a shared-memory region
    attach,         ///< a link session becomes the receiving end of a connection
    connect,        ///< SRC -> DST with a carrier
    disconnect,     ///< SRC -> DST
    stats,          ///< `plexus stats`
    param,          ///< `plexus param get|set`
    param_recv,     ///< the receiving half of param, asked of DST's daemon
    ping,           ///< where a port lives; also the name server's "are you there"
    events,         ///< `plexus events`
    node,           ///< the daemon's node name, address and name server
    lookup,         ///< where a port lives (also relayed by a daemon to the name server)
    list,           ///< every port and connection (also relayed)
    inspect,        ///< a daemon's part of the whole system's view (its stats and arbitration), for the web
    record_start,   ///< `plexus record`: this daemon records ports into a file of its own
    record_status,  ///< how a recording goes
    record_stop,    ///< ends a recording; the answer says what it kept and lost
    report,         ///< a client's own counters for one of its ports (a bridge's drops), shown by stats
    // The name server's.
    register_node,
    register_port,
    unregister_port,
    add_connection,
    remove_connection,
    mcast_group,  ///< the multicast group of a source port
    discover,     ///< multicast only: where is the name server
};

/// The name on the wire ("open", "register_node", ...).
std::string_view op_name(Op op);
/// The operation a name stands for; nullopt for a name no peer of this version knows.
std::optional<Op> op_named(std::string_view name);
/// A request body: {"op": NAME} with `fields` (a map) merged in.
nlohmann::json request_body(Op op, nlohmann::json fields = nlohmann::json::object());

}  // namespace plexus::proto
