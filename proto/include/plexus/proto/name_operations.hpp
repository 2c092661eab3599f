#pragma once
// The requests and replies of the name server's operations (PROTOCOL.md, "The name server"), in
// the style of operations.hpp (which says how encode and decode behave). `ping` is asked with
// operations.hpp's PingRequest; the name server answers it with NamesPingReply.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/operations.hpp"

namespace plexus::proto {

/// The name server's answer to `ping`.
struct NamesPingReply {
    std::string names;                     ///< its address, HOST:PORT
    std::uint64_t auth_failures = 0;       ///< TCP peers that failed authentication
    std::uint64_t handshake_timeouts = 0;  ///< TCP peers cut off for not finishing it in time
    /// Encrypted links cut off for a record that failed its check; absent from an older server.
    std::optional<std::uint64_t> tls_records_refused;
    /// Connections refused at accept for their peer's limits (peer_limits); absent from an older server.
    std::optional<std::uint64_t> peers_refused;
    /// register_node refused for a node its asker's certificate does not name (identities).
    std::optional<std::uint64_t> identities_refused;
    /// Requests refused by the name server's permissions file.
    std::optional<std::uint64_t> permission_refusals;
    nlohmann::json encode() const;                                     ///< the reply body
    static Result<NamesPingReply> decode(const nlohmann::json& body);  ///< from a reply body
};

/// `lookup`: where a port lives (a daemon relays it to the name server).
struct LookupRequest {
    static constexpr Op op = Op::lookup;
    std::string port;                                                 ///< the port asked about
    nlohmann::json encode() const;                                    ///< the request body
    static Result<LookupRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `lookup` (code 1 when the port is not registered).
struct LookupReply {
    std::string port;               ///< the port
    std::string node;               ///< the node it lives on
    std::string address;            ///< that node daemon's TCP address, HOST:PORT
    nlohmann::json encode() const;  ///< the reply body
    static Result<LookupReply> decode(const nlohmann::json& body);  ///< from a reply body
};

/// `list`: every port and connection the name server knows (a daemon relays it).
struct ListRequest {
    static constexpr Op op = Op::list;
    nlohmann::json encode() const;                                  ///< the request body
    static Result<ListRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `list`: the documented output of `plexus list --json`, carried whole for the
/// reason StatsReply is (names/registry.cpp writes it); decode checks the two lists are lists.
struct ListReply {
    nlohmann::json document = {{"ports", nlohmann::json::array()},
                               {"connections", nlohmann::json::array()}};  ///< {"ports", "connections"}
    nlohmann::json encode() const;                                         ///< the reply body
    static Result<ListReply> decode(const nlohmann::json& body);           ///< from a reply body
};

/// `register_node`: the first request of a daemon's session.
struct RegisterNodeRequest {
    static constexpr Op op = Op::register_node;
    std::string node;               ///< the daemon's node name
    std::string address;            ///< its TCP address, HOST:PORT, as it sees it
    nlohmann::json encode() const;  ///< the request body
    static Result<RegisterNodeRequest> decode(const nlohmann::json& body);  ///< from a request body
};
using RegisterNodeReply = EmptyReply;

/// `register_port`: a port of the session's node opened.
struct RegisterPortRequest {
    static constexpr Op op = Op::register_port;
    std::string port;                                                       ///< the port
    nlohmann::json encode() const;                                          ///< the request body
    static Result<RegisterPortRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// A remembered (persistent) connection that names a port.
struct PersistentConnection {
    std::string source;       ///< the sending port
    std::string destination;  ///< the receiving port
    std::string carrier;      ///< its carrier text
};
/// The answer to `register_port`.
struct RegisterPortReply {
    std::vector<PersistentConnection> persistent;                         ///< the connections to make again
    nlohmann::json encode() const;                                        ///< the reply body
    static Result<RegisterPortReply> decode(const nlohmann::json& body);  ///< from a reply body
};

/// `unregister_port`: a port of the session's node closed.
struct UnregisterPortRequest {
    static constexpr Op op = Op::unregister_port;
    std::string port;                                                         ///< the port
    nlohmann::json encode() const;                                            ///< the request body
    static Result<UnregisterPortRequest> decode(const nlohmann::json& body);  ///< from a request body
};
using UnregisterPortReply = EmptyReply;

/// `add_connection`: the daemon of the source made (or re-carried) a connection.
struct AddConnectionRequest {
    static constexpr Op op = Op::add_connection;
    std::string source;             ///< the sending port, on the session's node
    std::string destination;        ///< the receiving port
    std::string carrier;            ///< its carrier text
    bool persistent = false;        ///< remember it in the state file
    nlohmann::json encode() const;  ///< the request body
    static Result<AddConnectionRequest> decode(const nlohmann::json& body);  ///< from a request body
};
using AddConnectionReply = EmptyReply;

/// `remove_connection`: a connection went down (`forget` false) or was disconnected (true).
struct RemoveConnectionRequest {
    static constexpr Op op = Op::remove_connection;
    std::string source;             ///< the sending port, on the session's node
    std::string destination;        ///< the receiving port
    bool forget = false;            ///< forget it even when it is persistent
    nlohmann::json encode() const;  ///< the request body
    static Result<RemoveConnectionRequest> decode(const nlohmann::json& body);  ///< from a request body
};
using RemoveConnectionReply = EmptyReply;

/// `mcast_group`: the multicast group of a source port, for the mcast carrier.
struct McastGroupRequest {
    static constexpr Op op = Op::mcast_group;
    std::string port;                                                     ///< the source port
    nlohmann::json encode() const;                                        ///< the request body
    static Result<McastGroupRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `mcast_group`.
struct McastGroupReply {
    std::string group;                                                  ///< "A.B.C.D:PORT"
    nlohmann::json encode() const;                                      ///< the reply body
    static Result<McastGroupReply> decode(const nlohmann::json& body);  ///< from a reply body
};

/// `discover`: a datagram to the discovery group asking where the name server is.
struct DiscoverRequest {
    static constexpr Op op = Op::discover;
    std::string nonce;  ///< fresh for each query: a name server with the secret proves itself over it
    nlohmann::json encode() const;                                      ///< the request body
    static Result<DiscoverRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `discover`.
struct DiscoverReply {
    std::string names;              ///< the name server's address; host 0.0.0.0 means "the one that answered"
    std::string proof;              ///< with a secret and a nonce: Secret::discovery_proof(nonce, names)
    nlohmann::json encode() const;  ///< the reply body
    static Result<DiscoverReply> decode(const nlohmann::json& body);  ///< from a reply body
};

}  // namespace plexus::proto
