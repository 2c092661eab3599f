#pragma once
// Threading: owned by the name server's one thread; no sockets, no locking.

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "name_protocol.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::daemon::names {

using Clock = std::chrono::steady_clock;

/// The name server's state: nodes (daemons) tied to their sessions, their ports, and connections.
/// When a node's session ends its ports stay for a grace period, so a daemon that reconnects (or a
/// name server blip) does not make ports flicker; after it they go.
/// Bounds on what one name server keeps: far above any robot system, low enough that a peer
/// looping registrations cannot exhaust its memory or the disk its state file is saved to.
inline constexpr std::size_t max_nodes = 4096;
inline constexpr std::size_t max_ports = 100000;
inline constexpr std::size_t max_connections = 10000;  // kept in a list: each add scans it
inline constexpr std::size_t max_node_text = 255;      ///< node names and addresses
inline constexpr std::size_t max_carrier_text = 4096;

class Registry {
public:
    explicit Registry(Clock::duration grace) : grace_(grace) {}

    /// A daemon says who it is. Refused if another live session holds that node name.
    proto::Status register_node(const std::string& node, const std::string& address, std::uint64_t session);
    proto::Status register_port(const std::string& name, std::uint64_t session);
    proto::Status unregister_port(const std::string& name, std::uint64_t session);
    std::optional<PortEntry> lookup(const std::string& name) const;

    proto::Status add_connection(ConnectionEntry entry, std::uint64_t session);
    /// Only the node that owns `source` may add or remove its connections.
    proto::Status remove_connection(const std::string& source, const std::string& destination,
                                    std::uint64_t session);
    /// Persistent connections that name `port` at either end.
    std::vector<ConnectionEntry> persistent_for(const std::string& port) const;
    std::vector<ConnectionEntry> persistent() const;
    void restore_persistent(std::vector<ConnectionEntry> entries);

    /// The session ended: its node becomes an orphan until `expire` passes the grace period.
    void session_closed(std::uint64_t session, Clock::time_point now);
    /// Removes the ports and live connections of nodes orphaned longer than the grace period.
    /// Returns the names of the ports removed.
    std::vector<std::string> expire(Clock::time_point now);

    nlohmann::json list() const;
    std::size_t port_count() const { return ports_.size(); }

private:
    struct Node {
        std::string address;
        std::uint64_t session = 0;  ///< 0 while orphaned
        Clock::time_point orphaned_at;
    };
    const Node* node_of_session(std::uint64_t session, std::string* name) const;
    proto::Status owns_source(const std::string& source, std::uint64_t session) const;
    void remove_ports_of(const std::string& node, std::vector<std::string>& removed);

    Clock::duration grace_;
    std::map<std::string, Node> nodes_;
    std::map<std::string, PortEntry> ports_;
    std::vector<ConnectionEntry> connections_;
};

}  // namespace plexus::daemon::names
