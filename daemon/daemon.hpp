#pragma once
// Threading: the whole daemon runs on one io_context thread (like Redis and Mosquitto); no locks.

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arbitration/clock.hpp"
#include "core/router.hpp"
#include "monitor/monitor.hpp"
#include "names/name_client.hpp"
#include "names/name_server.hpp"
#include "net/asio.hpp"
#include "net/shm_region.hpp"
#include "net/signal.hpp"
#include "plexus/proto/control.hpp"

namespace plexus::daemon {

class Session;
class ScriptHost;

struct DaemonConfig {
    proto::Endpoint names{"127.0.0.1", 10100};
    bool embedded_names = false;
    std::string names_state;  ///< state file of the embedded name server
    proto::Endpoint listen{"127.0.0.1", 0};
    std::string socket_path;
    std::string node;
    std::vector<std::string> script_dirs;
    std::string ready_file;  ///< written (JSON: node, address, socket, names) once registered
    std::size_t max_frame = proto::default_max_frame;
    std::size_t default_capacity = 1024;  ///< reader queue length when a client does not say
    std::size_t link_capacity = 1024;     ///< messages queued towards another daemon per connection
    std::size_t queue_bytes = ReaderQueue::default_max_bytes;  ///< byte bound of every queue
    std::chrono::milliseconds names_grace{2000};
    monitor::MonitorPolicy monitors;  ///< memory cap, time budget, quarantine of every port monitor
    /// Least size of the shared-memory region a local client may get per port it writes large
    /// payloads through (a region holds at least four of the port's first large payload); 0 turns
    /// shared memory off. Small on purpose: the slots in use stay warm in the cache, and fewer
    /// messages wait in a region (8 MiB against 32: 1 MiB fan-out to 8 readers 5,365 against
    /// 3,993 deliveries/s, p50 under load 3.4 against 30 ms).
    std::size_t shm_region_bytes = 8u * 1024u * 1024u;
    /// Bound on the bytes of all regions together.
    std::size_t shm_total_bytes = 1024u * 1024u * 1024u;
};

/// Daemon-wide counters that `plexus stats` shows.
struct DaemonCounters {
    std::uint64_t sessions_accepted = 0;
    std::uint64_t accept_errors = 0;         ///< failed accepts (e.g. out of file descriptors)
    std::uint64_t protocol_errors = 0;       ///< peers cut off for breaking the protocol
    std::uint64_t dropped_unknown_port = 0;  ///< data frames for a handle that is not open
    std::uint64_t dropped_link_down = 0;     ///< messages queued to another daemon when the link died
    std::uint64_t shm_passed = 0;            ///< messages whose payload went to readers in shared memory
    std::uint64_t shm_copied = 0;  ///< written in shared memory, copied out for readers that needed it
};

/// The node daemon: hosts ports for local clients, connects them, moves data.
class Daemon {
public:
    Daemon(asio::io_context& io, DaemonConfig config);
    ~Daemon();
    Daemon(const Daemon&) = delete;
    Daemon& operator=(const Daemon&) = delete;

    /// Binds, starts, runs until SIGINT/SIGTERM; returns the exit status.
    int run();

    // --- used by sessions ---
    Task<proto::Reply> handle(std::shared_ptr<Session> session, proto::Request request);
    void session_closed(Session& session);
    /// Called whenever a strict queue drops below capacity: wakes writers held back.
    void notify_space() { space_.notify(); }
    Signal& space() { return space_; }
    DaemonCounters& counters() { return counters_; }
    const DaemonConfig& config() const { return config_; }
    Router& router() { return router_; }
    std::uint64_t next_session_id() { return next_session_++; }
    /// The session with this id, if it is still open.
    std::shared_ptr<Session> session(std::uint64_t id) const;

    // --- used by the script host ---
    /// Opens a port that the daemon itself writes (a monitor's publish port) and registers it.
    proto::Result<std::shared_ptr<Port>> open_hosted_port(const std::string& name);
    void close_hosted_port(std::shared_ptr<Port> port) { forget_port(std::move(port)); }

private:
    proto::Status bind();
    Task<void> accept_tcp();
    Task<void> accept_unix();
    /// Pauses the accept loop after a failed accept.
    Task<void> back_off_after_accept_error();
    Task<void> shutdown();
    Task<void> announce_ready();
    void start_session(Socket socket, const std::string& description);

    Task<proto::Reply> open_port(std::shared_ptr<Session> session, const proto::Request& request);
    Task<proto::Reply> close_port(std::shared_ptr<Session> session, const proto::Request& request);
    Task<proto::Reply> connect(const proto::Request& request);
    Task<proto::Reply> connect_remote(const proto::Request& request, std::shared_ptr<Port> source,
                                      std::string destination, std::string carrier, std::string address,
                                      std::shared_ptr<monitor::MonitorChain> send_chain);
    Task<proto::Reply> disconnect(const proto::Request& request);
    Task<proto::Reply> attach(std::shared_ptr<Session> session, const proto::Request& request);
    Task<proto::Reply> stats(const proto::Request& request);
    /// `shm`: the client maps shared-memory regions; with a handle, it gets one for that port.
    Task<proto::Reply> shm(std::shared_ptr<Session> session, const proto::Request& request);
    Task<proto::Reply> param(const proto::Request& request);
    /// The recv half of `plexus param`: the monitors of the inlet source -> destination here.
    Task<proto::Reply> param_recv(const proto::Request& request);
    Task<proto::Reply> ping(const proto::Request& request);
    // Arbitration (arbitration_requests.cpp).
    /// A new connection's place in the arbitration of `port`, configured from the carrier.
    proto::Result<std::shared_ptr<arbitration::Member>> new_member(const std::shared_ptr<Port>& port,
                                                                   const std::string& source,
                                                                   const proto::Carrier& carrier);
    /// Checks a member before it joins: weights that make the system singular are an error;
    /// constraints that overlap another connection's are warnings (errors with `strict`).
    proto::Result<nlohmann::json> check_member(const Port& port, const arbitration::Member& member,
                                               bool strict);
    /// `plexus events PORT`: the port's event container and arbitration state.
    Task<proto::Reply> events(const proto::Request& request);
    nlohmann::json events_json(const Port& port, bool check) const;
    Task<proto::Reply> ask_names(const proto::Request& request, nlohmann::json body);
    /// Sends the request to the daemon that hosts `port` and relays its reply.
    Task<proto::Reply> forward(const proto::Request& request, const std::string& port);
    void forget_port(std::shared_ptr<Port> port);
    /// Makes the remembered connections of a port that just registered.
    Task<void> restore_persistent(std::vector<names::ConnectionEntry> persistent);
    nlohmann::json stats_json(const std::string& only_port) const;
    std::string address() const;
    // GCC 12 miscompiles braced temporaries and lambdas inside co_await expressions: build them
    // in these plain functions instead.
    proto::Hello our_hello(const char* role) const;
    std::function<void()> space_notifier();

    asio::io_context& io_;
    DaemonConfig config_;
    std::unique_ptr<ScriptHost> scripts_;  ///< before router_: monitors in connections die first
    arbitration::SteadyClock clock_;       ///< event lifetimes and stimulation decay
    Router router_;
    Signal space_;
    DaemonCounters counters_;
    std::unique_ptr<names::NameServer> embedded_names_;
    std::unique_ptr<names::NameClient> names_;
    asio::ip::tcp::acceptor tcp_acceptor_;
    asio::local::stream_protocol::acceptor unix_acceptor_;
    asio::signal_set signals_;
    std::map<std::uint64_t, std::weak_ptr<Session>> sessions_;
    std::vector<std::weak_ptr<Peer>> links_;  ///< sending ends of tcp connections, flushed at shutdown
    std::uint64_t next_session_ = 1;
    std::shared_ptr<ShmUsage> shm_usage_ = std::make_shared<ShmUsage>();
    std::uint64_t next_region_ = 1;
    bool stopping_ = false;
};

}  // namespace plexus::daemon
