#pragma once
// Threading: the daemon runs on one io_context, one thread at a time (like Redis and Mosquitto); no
// locks. That thread is the main one, or the LoopStandIn while a cheap monitor running inline
// overruns (monitor/loop_stand_in.hpp). With `--threads N` (N > 1) local sessions and their ports
// run on N data threads beside it, and the gates (net/handler_gate.hpp) keep this thread's
// handlers and theirs apart: what is written here for one thread stays right.

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arbitration/clock.hpp"
#include "control/control_host.hpp"
#include "control/control_plane.hpp"
#include "core/router.hpp"
#include "daemon_config.hpp"
#include "heap_trimmer.hpp"
#include "monitor/monitor.hpp"
#include "monitor/workers.hpp"
#include "names/name_client.hpp"
#include "names/name_server.hpp"
#include "net/asio.hpp"
#include "net/call_table.hpp"
#include "net/peer_limits.hpp"
#include "net/session_host.hpp"
#include "net/shards.hpp"
#include "net/signal.hpp"
#include "net/udp_socket.hpp"
#include "plexus/proto/control.hpp"
#include "web/http_server.hpp"

namespace plexus::daemon {

class Session;
class ScriptHost;

/// The node daemon: hosts ports for local clients, connects them, moves data. It binds, accepts
/// sessions and shuts down; its control plane (control/) answers the sessions' requests, and
/// reaches the daemon through ControlHost.
class Daemon final : public ControlHost, public SessionHost {
public:
    Daemon(asio::io_context& io, DaemonConfig config);
    ~Daemon() override;
    Daemon(const Daemon&) = delete;
    Daemon& operator=(const Daemon&) = delete;

    /// Binds, starts, runs until SIGINT/SIGTERM; returns the exit status.
    int run();

    // --- SessionHost, used by sessions ---
    Task<proto::Reply> handle_request(std::shared_ptr<Session> session, proto::Request request) override {
        return control_.handle(std::move(session), std::move(request));
    }
    void session_closed(Session& session) override;
    void expect_space() override { shards_.current().expect_space(); }
    Task<bool> wait_for_space(std::chrono::steady_clock::duration timeout) override {
        return shards_.current().wait_for_space(timeout);
    }
    asio::any_io_executor control_executor() override { return io_.get_executor(); }
    std::shared_ptr<Session> session(std::uint64_t id) const override;
    std::uint64_t next_session_id() { return next_session_++; }

    // --- used by the script host ---
    /// Opens a port that the daemon itself writes (a monitor's publish port) and registers it.
    proto::Result<std::shared_ptr<Port>> open_hosted_port(const std::string& name);
    void close_hosted_port(std::shared_ptr<Port> port) { forget_port(std::move(port)); }

    // --- ControlHost, used by the control plane (the config and counters by sessions too) ---
    const DaemonConfig& config() const override { return config_; }
    std::string address() const override;
    std::string http_address() const override;
    bool http_tls() const override;
    std::string http_fingerprint() const override;
    nlohmann::json http_counters() const override;
    Router& router() override { return router_; }
    names::NameClient& names() override { return *names_; }
    MonitorWiring& scripts() override;
    UdpSocket& udp() override { return udp_; }
    Task<proto::Result<std::string>> mcast_group(std::string source) override {
        return names_->mcast_group(std::move(source));
    }
    const arbitration::Clock& clock() const override { return clock_; }
    /// The calling thread's counters (each of the daemon's threads keeps its own).
    DaemonCounters& counters() override { return shards_.current().counters(); }
    DaemonCounters total_counters() const override { return shards_.total(); }
    CallTable& calls() override { return *calls_; }
    std::size_t session_count() const override { return sessions_.size(); }
    bool stopping() const override { return stopping_; }
    /// Called whenever a strict queue drops below capacity: wakes writers held back.
    void notify_space() override { shards_.space_appeared(); }
    void forget_port(std::shared_ptr<Port> port) override;
    void keep_link(std::weak_ptr<Peer> link) override { links_.push_back(std::move(link)); }

private:
    proto::Status bind();
    /// What the name server is told: --advertise's host if given, else address().
    std::string advertised_address() const;
    Task<void> accept_tcp();
    Task<void> accept_unix();
    /// Pauses the accept loop after a failed accept.
    Task<void> back_off_after_accept_error();
    Task<void> shutdown();
    /// Arms the SIGINT/SIGTERM handler: the first starts shutdown(), a second stops at once.
    void wait_for_signal();
    /// SIGHUP: the permissions files (the daemon's, the embedded name server's) are read again.
    void wait_for_reload();
    Task<void> announce_ready();
    /// Starts a session on `shard` (0: this thread; else a data thread, the socket moved there).
    /// `description` names the session in the log ("local session"), followed by its number and
    /// `peer` (a local client's uid, gid and pid); `local_user` is the local client's uid, for the
    /// permissions.
    void start_session(Socket socket, const std::string& description, std::size_t shard = 0,
                       const std::string& peer = "", std::unique_ptr<PeerLimits::Ticket> ticket = nullptr,
                       std::optional<uid_t> local_user = std::nullopt);
    /// Counts a new connection against its peer's limits; null (counted, logged) when it is refused.
    std::unique_ptr<PeerLimits::Ticket> admit_peer(PeerLimits& limits, const std::string& peer);
    /// What session_closed() does, on this thread.
    void forget_session(Session& session);

    asio::io_context& io_;
    DaemonConfig config_;
    /// The data threads (`--threads`); stopped by run() before it returns, while the rest exists.
    Shards shards_;
    /// The threads monitors run on; shared with the stages, which may outlive the daemon (see stage.hpp).
    std::shared_ptr<monitor::Workers> workers_;
    std::unique_ptr<ScriptHost> scripts_;  ///< before router_: monitors in connections die first
    arbitration::SteadyClock clock_;       ///< event lifetimes and stimulation decay
    Router router_;
    std::shared_ptr<CallTable> calls_;  ///< made first thing: sessions and links use it
    std::unique_ptr<names::NameServer> embedded_names_;
    std::unique_ptr<names::NameClient> names_;
    asio::ip::tcp::acceptor tcp_acceptor_;
    asio::local::stream_protocol::acceptor unix_acceptor_;
    UdpSocket udp_;
    std::shared_ptr<PeerLimits> tcp_peers_;    ///< by IP address: connections, handshakes, failed proofs
    std::shared_ptr<PeerLimits> local_peers_;  ///< by uid: connections only (no secret to fail)
    asio::signal_set signals_;
    asio::signal_set reload_signals_;  ///< SIGHUP: the permissions file is read again
    std::map<std::uint64_t, std::weak_ptr<Session>> sessions_;
    std::vector<std::weak_ptr<Peer>> links_;  ///< sending ends of tcp connections, flushed at shutdown
    std::uint64_t next_session_ = 1;
    ControlPlane control_;
    HeapTrimmer heap_trimmer_;
    std::unique_ptr<web::HttpServer> http_;  ///< the web endpoint, with --http; after control_ (reads it)
    bool stopping_ = false;
    int exit_status_ = 0;  ///< what run() returns: 4 when the name server refused this node at start
    /// The Unix socket file is ours to remove at exit (shutdown closes the acceptor before that).
    bool socket_bound_ = false;
};

}  // namespace plexus::daemon
