#pragma once
// Threading: runs on the io_context it is given, one thread; no locking.

#include <memory>
#include <optional>
#include <string>

#include "../net/asio.hpp"
#include "../net/peer_limits.hpp"
#include "../net/permission_gate.hpp"
#include "plexus/proto/auth.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/endpoint.hpp"
#include "plexus/proto/identity.hpp"
#include "plexus/proto/ops.hpp"
#include "reachable_address.hpp"
#include "registry.hpp"

namespace plexus::daemon::names {

struct NameServerConfig {
    proto::Endpoint listen{"127.0.0.1", 10100};
    std::string state_file;  ///< where persistent connections are kept; empty = not kept
    std::chrono::milliseconds grace{2000};
    /// A TCP peer that has not completed its handshake this long after connecting is cut off.
    std::chrono::milliseconds handshake_timeout{10000};
    std::size_t max_frame = 1024 * 1024;
    /// The multicast group it answers discovery queries on; none = no discovery. Only joined when
    /// it listens beyond loopback (a query never reaches a loopback-only name server anyway).
    std::optional<proto::Endpoint> discovery;
    /// The deployment secret: every TCP peer must prove it holds it (see FramedConnection).
    std::optional<proto::Secret> secret;
    /// --permissions: which node may register which ports ("open"); null: any node any port.
    std::shared_ptr<const Permissions> permissions;
    /// Where mcast groups are given out from (one per source port asking): a first IPv4 group
    /// address and a count, all on one UDP port.
    std::uint32_t mcast_first = (239u << 24) | (255u << 16) | (81u << 8);  // 239.255.81.0
    std::uint32_t mcast_count = 256;
    std::uint16_t mcast_port = 10102;
    /// What one TCP peer (an IP address) may hold at once: connections, handshakes in flight,
    /// failed proofs of the secret a minute (a daemon's config keys peer_*, which an embedded
    /// name server shares).
    PeerLimitConfig peer_limits;
};

/// The name server: ports and daemons over TCP; the same port number over UDP answers the
/// read-only look-ups (lookup, list, ping) in one datagram each.
class NameServer {
public:
    NameServer(asio::io_context& io, NameServerConfig config);
    ~NameServer();
    NameServer(const NameServer&) = delete;
    NameServer& operator=(const NameServer&) = delete;

    /// Loads the state file and binds TCP and UDP. Errors say what failed and where.
    proto::Status start();
    void stop();
    /// The --permissions checks of register_port (SIGHUP reloads their file).
    PermissionGate& permissions() { return permissions_; }
    /// The bound address (with the real port when 0 was asked for).
    proto::Endpoint endpoint() const;

    /// Answers one request for `session` (0 = a UDP datagram, read-only), whose ends are at `where`;
    /// never throws.
    /// `certified`: what the session's certificate names (identities), else null.
    proto::Reply answer(const proto::Request& request, std::uint64_t session,
                        const SessionAddresses& where = {}, const proto::Subject* certified = nullptr);
    void session_closed(std::uint64_t session);
    std::size_t max_frame() const { return config_.max_frame; }
    /// Peers that failed to prove they hold the secret.
    void count_auth_failure() { ++auth_failures_; }
    std::uint64_t auth_failures() const { return auth_failures_; }
    void count_handshake_timeout() { ++handshake_timeouts_; }
    void count_tls_refused() { ++tls_records_refused_; }
    std::uint64_t peers_refused() const { return peers_refused_; }

private:
    Task<void> accept_loop();
    Task<void> udp_loop();
    /// Joins the discovery group, if any; an Error says why it could not.
    proto::Status start_discovery();
    Task<void> discovery_loop();
    void save_state();
    /// One request as its handler sees it.
    struct Asked {
        const proto::Request& request;
        std::uint64_t session;  ///< 0: a UDP datagram
        const SessionAddresses& where;
        const proto::Subject* certified;  ///< what the session's certificate names; null without identities
    };
    using Handler = proto::Reply (NameServer::*)(const Asked& asked);
    /// Who may send an op: anyone (also over UDP, read-only look-ups), or TCP sessions only.
    enum class Callers { anyone, tcp };
    struct Operation {
        proto::Op op;
        Callers callers;
        Handler handler;
    };
    /// The table (name_operations.cpp), in the daemon's control plane's style: to add an op,
    /// write its handler, add a row, list it in PROTOCOL.md.
    static const Operation operations_[];
    proto::Reply handle(const proto::Request& request, std::uint64_t session, const SessionAddresses& where,
                        const proto::Subject* certified);
    // name_operations.cpp: one handler per op.
    /// Counts a connection refused for its peer's limits and logs it, at most one line a second.
    void refused(const std::string& peer, PeerLimits::Refusal refusal);
    proto::Reply ping(const Asked& asked);
    proto::Reply lookup(const Asked& asked);
    proto::Reply list(const Asked& asked);
    proto::Reply mcast_group(const Asked& asked);
    proto::Reply register_node(const Asked& asked);
    proto::Reply register_port(const Asked& asked);
    proto::Reply unregister_port(const Asked& asked);
    proto::Reply add_connection(const Asked& asked);
    proto::Reply remove_connection(const Asked& asked);

    asio::io_context& io_;
    NameServerConfig config_;
    Registry registry_;
    asio::ip::tcp::acceptor acceptor_;
    asio::ip::udp::socket udp_;
    asio::ip::udp::socket discovery_;
    std::uint64_t next_session_ = 1;
    std::uint64_t auth_failures_ = 0;
    std::uint64_t handshake_timeouts_ = 0;
    std::uint64_t tls_records_refused_ = 0;
    std::uint64_t peers_refused_ = 0;      ///< connections refused at accept for their peer's limits
    std::uint64_t identity_refusals_ = 0;  ///< register_node for a node the certificate does not name
    std::shared_ptr<PeerLimits> peers_;
    PermissionGate permissions_;  ///< which node may register which ports
    bool stopped_ = false;
};

}  // namespace plexus::daemon::names
