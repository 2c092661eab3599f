#pragma once
// Threading: owned by the name server's one thread; no sockets, no locking.

#include <chrono>
#include <cstdint>
#include <deque>
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

    /// The multicast group of `port` ("A.B.C.D:PORT"), given out from the range the first time it
    /// is asked for and the same for as long as the port stays registered. A port that goes gives
    /// its group back; groups never given out come first, then those given back, oldest first, so
    /// that a group is reused as late as possible (a reader still joined to it drops what is not
    /// from its source). An Error when the port is not registered or every group is in use.
    proto::Result<std::string> mcast_group(const std::string& port);
    /// The range groups are given out from: `first` (an IPv4 multicast address, as a number),
    /// `count` addresses, all on UDP port `udp_port`.
    void set_mcast_range(std::uint32_t first, std::uint32_t count, std::uint16_t udp_port) {
        mcast_first_ = first;
        mcast_count_ = count;
        mcast_port_ = udp_port;
    }

    nlohmann::json list() const;
    std::size_t port_count() const { return ports_.size(); }
    /// The node that `session` registered; nullopt before it registered one.
    std::optional<std::string> node_named_by(std::uint64_t session) const {
        std::string name;
        if (!node_of_session(session, &name))
            return std::nullopt;
        return name;
    }

private:
    struct Node {
        std::string address;
        std::uint64_t session = 0;  ///< 0 while orphaned
        Clock::time_point orphaned_at;
    };
    const Node* node_of_session(std::uint64_t session, std::string* name) const;
    proto::Status owns_source(const std::string& source, std::uint64_t session) const;
    void remove_ports_of(const std::string& node, std::vector<std::string>& removed);
    /// The port is gone: its multicast group, if it had one, can be given to another.
    void release_mcast_group(const std::string& port);

    Clock::duration grace_;
    std::map<std::string, Node> nodes_;
    std::map<std::string, PortEntry> ports_;
    std::vector<ConnectionEntry> connections_;
    std::map<std::string, std::uint32_t> mcast_groups_;                     ///< port -> offset in the range
    std::uint32_t mcast_next_fresh_ = 0;                                    ///< offsets below were given out
    std::deque<std::uint32_t> mcast_released_;                              ///< given back, oldest first
    std::uint32_t mcast_first_ = (239u << 24) | (255u << 16) | (81u << 8);  // 239.255.81.0
    std::uint32_t mcast_count_ = 256;
    std::uint16_t mcast_port_ = 10102;
};

}  // namespace plexus::daemon::names
