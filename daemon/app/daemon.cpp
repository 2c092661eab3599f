#include "daemon.hpp"
#include "trust.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string_view>

#include <spdlog/spdlog.h>

#include "net/call_table.hpp"
#include "net/keepalive.hpp"
#include "net/session.hpp"
#include "plexus/proto/discovery.hpp"
#include "script_host.hpp"
#include "socket_directory.hpp"

namespace plexus::daemon {

namespace {
constexpr auto shutdown_grace = std::chrono::seconds(3);
/// Of which monitors may use this much to finish what they hold (SIGTERM must end a daemon within
/// 2 s whatever a script is doing).
constexpr auto monitors_grace = std::chrono::seconds(1);
/// Of which telling the name server that the ports go may use this much (a name server that does
/// not answer must not keep the daemon alive).
constexpr auto unregister_grace = std::chrono::seconds(1);
}  // namespace

Daemon::Daemon(asio::io_context& io, DaemonConfig config)
    : io_(io),
      config_(std::move(config)),
      shards_(io, config_.threads),
      tcp_acceptor_(io),
      unix_acceptor_(io),
      udp_(io, config_.udp, config_.secret),
      tcp_peers_(std::make_shared<PeerLimits>(config_.peer_limits)),
      // A local client proves nothing, and a robot's launch may start dozens of components of one
      // user at once: only their number is bounded.
      local_peers_(std::make_shared<PeerLimits>(
          PeerLimitConfig{config_.peer_limits.connections, config_.peer_limits.connections, 0})),
      signals_(io, SIGINT, SIGTERM),
      reload_signals_(io, SIGHUP),
      control_(io.get_executor(), *this),
      heap_trimmer_(io, HeapTrimmer::Settings{}) {
    calls_ = std::make_shared<CallTable>(io.get_executor());
    const bool inline_monitors = config_.monitors.inline_cost_limit.count() > 0;
    workers_ = std::make_shared<monitor::Workers>(config_.monitor_threads, inline_monitors ? &io_ : nullptr);
    scripts_ = std::make_unique<ScriptHost>(io_, *this, workers_);
    if (auto* stand_in = workers_->stand_in(); stand_in && shards_.data_threads() > 0) {
        // A script overrunning inline keeps the control thread: the data threads go on meanwhile.
        stand_in->set_hand_over({[this] { shards_.lend_gates(); }, [this] { shards_.act_as_control(); },
                                 [this] { shards_.stop_acting_as_control(); },
                                 [this] { shards_.reclaim_gates(); }});
    }
    // A connection from a port of a data thread to a sink on another thread crosses in mail.
    router_.crossing_for = [this](const Port& source, const std::shared_ptr<MessageSink>& sink) {
        return shards_.crossing(source.shard(), sink);
    };
}

Daemon::~Daemon() {
    // Monitors call back into the script host when they go: let them go while it still exists,
    // even those held by sessions that outlive the daemon. They go on their workers; wait for that.
    for (const auto& [name, port] : router_.ports()) {
        for (auto& connection : port->outgoing) {
            if (connection->send_monitors)
                connection->send_monitors->close();
        }
        for (const auto& weak : port->inbound) {
            if (auto inlet = weak.lock(); inlet && inlet->monitors)
                inlet->monitors->close();
        }
    }
    workers_->finish();
    if (!config_.socket_path.empty() && socket_bound_) {
        std::error_code ignored;
        std::filesystem::remove(config_.socket_path, ignored);
    }
}

std::string Daemon::address() const {
    boost::system::error_code ec;
    auto local = tcp_acceptor_.local_endpoint(ec);
    return config_.listen.host + ":" + std::to_string(ec ? 0 : local.port());
}

bool Daemon::http_tls() const {
    return http_ && http_->tls();
}

std::string Daemon::http_fingerprint() const {
    return http_ ? http_->fingerprint() : std::string();
}

std::string Daemon::http_address() const {
    return http_ ? http_->address() : std::string();
}

nlohmann::json Daemon::http_counters() const {
    return http_ ? http_->counters().to_json() : nlohmann::json();
}

std::string Daemon::advertised_address() const {
    if (config_.advertise.empty())
        return address();
    boost::system::error_code ec;
    auto local = tcp_acceptor_.local_endpoint(ec);
    return proto::Endpoint{config_.advertise, static_cast<std::uint16_t>(ec ? 0 : local.port())}.text();
}

proto::Status Daemon::bind() {
    if (config_.embedded_names) {
        names::NameServerConfig names_config;
        names_config.listen = config_.names;
        names_config.state_file = config_.names_state;
        names_config.grace = config_.names_grace;
        names_config.handshake_timeout = config_.handshake_timeout;
        names_config.secret = config_.secret;
        names_config.permissions = config_.permissions;
        names_config.peer_limits = config_.peer_limits;
        if (auto group = proto::discovery_group(); group)
            names_config.discovery = *group;
        else
            return group.error();
        embedded_names_ = std::make_unique<names::NameServer>(io_, names_config);
        if (auto started = embedded_names_->start(); !started)
            return started;
        // With port 0 the name server picked a port: the daemon must use that one.
        config_.names = embedded_names_->endpoint();
    }
    boost::system::error_code ec;
    auto address = asio::ip::make_address(config_.listen.host, ec);
    if (ec)
        return proto::Error{"--listen host '" + config_.listen.host + "' is not an IP address"};
    asio::ip::tcp::endpoint endpoint(address, config_.listen.port);
    tcp_acceptor_.open(endpoint.protocol(), ec);
    if (!ec)
        tcp_acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec)
        tcp_acceptor_.bind(endpoint, ec);
    if (!ec)
        tcp_acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
        return proto::Error{"cannot listen on TCP " + config_.listen.text() + ": " + ec.message()};
    // The udp carrier listens on the same address and port number, so one number opens a daemon
    // to others in a firewall.
    if (auto bound = udp_.bind(address, tcp_acceptor_.local_endpoint().port()); !bound)
        return bound;

    std::error_code fs_error;
    const std::filesystem::path socket_path = std::filesystem::absolute(config_.socket_path, fs_error);
    if (auto directory = prepare_socket_directory(socket_path.parent_path()); !directory)
        return directory;
    if (std::filesystem::exists(socket_path)) {
        // Refuse to steal the socket of a daemon that is still running; clear one left by a crash.
        asio::local::stream_protocol::socket probe(io_);
        probe.connect(asio::local::stream_protocol::endpoint(config_.socket_path), ec);
        if (!ec)
            return proto::Error{"another daemon is already serving " + config_.socket_path};
        std::filesystem::remove(socket_path, fs_error);
    }
    unix_acceptor_.open(asio::local::stream_protocol(), ec);
    if (!ec)
        unix_acceptor_.bind(asio::local::stream_protocol::endpoint(config_.socket_path), ec);
    if (!ec)
        unix_acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
        return proto::Error{"cannot listen on Unix socket " + config_.socket_path + ": " + ec.message()};
    socket_bound_ = true;
    return proto::Ok{};
}

int Daemon::run() {
    if (auto bound = bind(); !bound) {
        spdlog::error("{}", bound.error().message);
        return 4;
    }
    if (config_.http.listen) {
        http_ = std::make_unique<web::HttpServer>(io_, config_.http, *this, control_.shm_usage());
        if (auto bound = http_->bind(); !bound) {
            spdlog::error("{}", bound.error().message);
            return 4;
        }
        http_->start();
        spdlog::info("web page at {}://{}/", http_->tls() ? "https" : "http", http_->address());
        if (!http_->fingerprint().empty())
            spdlog::info(
                "web page certificate: self-signed at this start, SHA-256 {} (check that the browser "
                "shows the same before accepting it; `plexus web` prints it too)",
                http_->fingerprint());
    }
    names_ = std::make_unique<names::NameClient>(io_, config_.names, config_.node, advertised_address(),
                                                 config_.max_frame, config_.secret);
    names_->ports_to_register = [this] {
        std::vector<std::string> names;
        for (const auto& [name, port] : router_.ports())
            names.push_back(name);
        return names;
    };
    names_->connections_to_register = [this] {
        std::vector<names::ConnectionEntry> connections;
        for (const auto& [name, port] : router_.ports()) {
            for (const auto& c : port->outgoing)
                connections.push_back({c->source, c->destination, c->carrier, c->persistent});
        }
        return connections;
    };
    names_->on_refused = [this](const std::string& why, bool ever_registered) {
        if (ever_registered)
            return;  // it has components running: keep them, and keep asking (requests fail with `why`)
        // Refused at start: no component can use a daemon the name server will not have.
        spdlog::error("the name server at {} refuses this daemon ({}); exiting", config_.names.text(), why);
        exit_status_ = 4;
        asio::co_spawn(io_, shutdown(), asio::detached);
    };
    names_->on_persistent = [this](std::vector<names::ConnectionEntry> persistent) {
        asio::co_spawn(io_, control_.restore_persistent(std::move(persistent)), asio::detached);
    };
    names_->start();
    asio::co_spawn(io_, announce_ready(), asio::detached);
    asio::co_spawn(io_, accept_tcp(), asio::detached);
    asio::co_spawn(io_, accept_unix(), asio::detached);
    udp_.start();
    // PLEXUS_HEAP_TRIM=0 keeps freed memory in the heap, as before the trimmer (for comparisons).
    if (const char* trim = std::getenv("PLEXUS_HEAP_TRIM"); !trim || std::string_view(trim) != "0")
        heap_trimmer_.start();
    wait_for_signal();
    wait_for_reload();
    spdlog::info("plexusd node '{}' listening on {} and {}; name server {}", config_.node, address(),
                 config_.socket_path, config_.names.text());
    shards_.start();
    io_.run();
    shards_.stop();
    // Coroutines still parked on a Signal (loops of connections that never closed) are destroyed
    // now, while the daemon they refer to still exists; otherwise their frames leak at exit.
    asio::use_service<SignalService>(io_).destroy_parked();
    return exit_status_;
}

void Daemon::wait_for_reload() {
    reload_signals_.async_wait([this](boost::system::error_code ec, int) {
        if (ec)
            return;
        reload_permissions(control_.permissions(), "");
        if (embedded_names_)
            reload_permissions(embedded_names_->permissions(), "names: ");
        wait_for_reload();
    });
}

void Daemon::wait_for_signal() {
    signals_.async_wait([this](boost::system::error_code ec, int signal) {
        if (ec)
            return;
        if (stopping_) {
            // A second signal: the caller will not wait for the grace period; stop at once.
            spdlog::warn("signal {} again: stopping now, without waiting for what is still in flight",
                         signal);
            io_.stop();
            return;
        }
        spdlog::info("signal {}: shutting down (a second signal stops at once)", signal);
        asio::co_spawn(io_, shutdown(), asio::detached);
        wait_for_signal();
    });
}

Task<void> Daemon::announce_ready() {
    if (config_.ready_file.empty())
        co_return;
    while (!stopping_ && !co_await names_->wait_connected(std::chrono::seconds(10))) {
        spdlog::warn("still waiting for the name server at {} before writing {}", config_.names.text(),
                     config_.ready_file);
    }
    if (stopping_)
        co_return;
    // Write then rename: whoever polls for the file never reads half of it.
    const nlohmann::json ready{{"node", config_.node},          {"address", address()},
                               {"socket", config_.socket_path}, {"names", config_.names.text()},
                               {"http", http_address()},        {"pid", static_cast<long>(::getpid())}};
    const std::string temporary = config_.ready_file + ".tmp";
    {
        std::ofstream out(temporary, std::ios::trunc);
        out << ready.dump() << '\n';
    }
    std::error_code ec;
    std::filesystem::rename(temporary, config_.ready_file, ec);
    if (ec)
        spdlog::error("cannot write ready file {}: {}", config_.ready_file, ec.message());
}

Task<void> Daemon::accept_tcp() {
    while (!stopping_) {
        auto [ec, socket] = co_await tcp_acceptor_.async_accept(use_nothrow);
        if (ec) {
            if (stopping_ || ec == asio::error::operation_aborted)
                co_return;
            spdlog::warn("accept on {} failed: {}", address(), ec.message());
            co_await back_off_after_accept_error();
            continue;
        }
        boost::system::error_code remote_error;
        auto remote = socket.remote_endpoint(remote_error);
        const std::string host = remote_error ? std::string("?") : remote.address().to_string();
        auto ticket = admit_peer(*tcp_peers_, "address " + host);
        if (!ticket)
            continue;  // the socket closes here
        socket.set_option(asio::ip::tcp::no_delay(true), ec);
        keep_alive(socket.native_handle());
        start_session(Socket(std::move(socket)),
                      "tcp session from " + host + (remote_error ? "" : ":" + std::to_string(remote.port())),
                      0, "", std::move(ticket));
    }
}

namespace {
/// The process at the other end of a Unix socket, as the kernel saw it connect.
std::optional<ucred> peer_credentials(int fd) {
    ucred peer{};
    socklen_t size = sizeof peer;
    if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &peer, &size) != 0)
        return std::nullopt;
    return peer;
}
}  // namespace

Task<void> Daemon::accept_unix() {
    while (!stopping_) {
        auto [ec, socket] = co_await unix_acceptor_.async_accept(use_nothrow);
        if (ec) {
            if (stopping_ || ec == asio::error::operation_aborted)
                co_return;
            spdlog::warn("accept on {} failed: {}", config_.socket_path, ec.message());
            co_await back_off_after_accept_error();
            continue;
        }
        // Every line the log writes about the session says which user's program it is.
        const auto peer = peer_credentials(socket.native_handle());
        const std::string about = peer ? " (uid " + std::to_string(peer->uid) + ", gid " +
                                             std::to_string(peer->gid) + ", pid " +
                                             std::to_string(peer->pid) + ")"
                                       : " (peer unknown)";
        auto ticket =
            admit_peer(*local_peers_, peer ? "uid " + std::to_string(peer->uid) : std::string("uid ?"));
        if (!ticket)
            continue;
        start_session(Socket(std::move(socket)), "local session", shards_.place(), about, std::move(ticket),
                      peer ? std::optional<uid_t>(peer->uid) : std::nullopt);
    }
}

MonitorWiring& Daemon::scripts() {
    return *scripts_;
}

std::unique_ptr<PeerLimits::Ticket> Daemon::admit_peer(PeerLimits& limits, const std::string& peer) {
    auto admission = limits.admit(peer);
    if (admission.ticket)
        return std::move(admission.ticket);
    ++counters().peers_refused;
    limits.log_refusal("", peer, admission.refusal);
    return nullptr;
}

Task<void> Daemon::back_off_after_accept_error() {
    // Out of file descriptors (or memory) the failure repeats at once: retrying without a pause
    // would spin the daemon's only thread and flood the log while sessions wait to close.
    ++counters().accept_errors;
    constexpr auto pause_length = std::chrono::milliseconds(100);
    asio::steady_timer pause(io_, pause_length);
    co_await pause.async_wait(use_nothrow);
}

void Daemon::start_session(Socket socket, const std::string& description, std::size_t shard,
                           const std::string& peer, std::unique_ptr<PeerLimits::Ticket> ticket,
                           std::optional<uid_t> local_user) {
    ++counters().sessions_accepted;
    const auto id = next_session_++;
    if (shard != 0) {
        // Its data thread runs it from now on: the socket moves to that thread's io_context.
        boost::system::error_code ec;
        const auto protocol = socket.local_endpoint(ec).protocol();
        if (ec) {
            spdlog::warn("{}: cannot move it to data thread {}: {}", description, shard, ec.message());
            return;
        }
        Socket moved(shards_[shard].io());
        moved.assign(protocol, socket.release(), ec);
        if (ec) {
            spdlog::warn("{}: cannot move it to data thread {}: {}", description, shard, ec.message());
            return;
        }
        socket = std::move(moved);
    }
    auto session = std::make_shared<Session>(std::move(socket), *this, id, shard);
    session->set_description(description + " #" + std::to_string(id) + peer);
    session->count_against_peer(std::move(ticket));
    if (local_user)
        session->set_local_user(*local_user);
    spdlog::debug("{} accepted", session->description());
    sessions_[id] = session;
    session->require_secret(config_.secret);  // only TCP peers are asked for it
    session->set_handshake_timeout(config_.handshake_timeout);
    proto::Hello hello{proto::protocol_version, "daemon", config_.node};
    hello.max_frame = config_.max_frame;  // a client refuses what would not fit before sending it
    session->start(hello);
}

std::shared_ptr<Session> Daemon::session(std::uint64_t id) const {
    const auto it = sessions_.find(id);
    return it == sessions_.end() ? nullptr : it->second.lock();
}

void Daemon::session_closed(Session& session) {
    if (Shards::here() == 0) {
        forget_session(session);
        return;
    }
    // A data thread's session: its ports and its entry are the control thread's to let go.
    auto self = std::static_pointer_cast<Session>(session.shared_from_this());
    asio::post(io_, [this, self] { forget_session(*self); });
}

void Daemon::forget_session(Session& session) {
    sessions_.erase(session.id());
    if (session.is_link())
        std::erase_if(session.link_port()->inbound, [&](const std::weak_ptr<Inlet>& inlet) {
            return inlet.expired() || inlet.lock() == session.link();
        });
    for (auto& port : session.take_ports())
        forget_port(port);
}

proto::Result<std::shared_ptr<Port>> Daemon::open_hosted_port(const std::string& name) {
    // Nobody reads a hosted port itself (readers connect to it), so its own queue stays empty.
    auto opened = router_.open(name, 0, QueuePolicy::latest, 1, config_.queue_bytes);
    if (!opened)
        return opened.error();
    if (!names_)
        return opened;
    auto tell = [](names::NameClient* names, Daemon* daemon, std::shared_ptr<Port> port) -> Task<void> {
        auto registered = co_await names->register_port(port->name());
        if (!registered) {
            spdlog::warn("port {} published by a monitor could not be registered: {}", port->name(),
                         registered.error().message);
            if (!port->closed())
                daemon->forget_port(port);
        }
    };
    asio::co_spawn(io_, tell(names_.get(), this, *opened), asio::detached);
    return opened;
}

void Daemon::forget_port(std::shared_ptr<Port> port) {
    const std::string name = port->name();
    auto removed = router_.close(name);
    notify_space();
    spdlog::info("port {} closed", name);
    if (stopping_ || !names_)
        return;
    std::vector<names::ConnectionEntry> gone;
    for (const auto& c : removed)
        gone.push_back({c->source, c->destination, c->carrier, false});
    names_->notify_port_closed(name, std::move(gone));
}

Task<void> Daemon::shutdown() {
    if (stopping_)
        co_return;
    spdlog::info("shutting down: {} ports, {} sessions", router_.ports().size(), sessions_.size());
    boost::system::error_code ignored;
    tcp_acceptor_.close(ignored);
    unix_acceptor_.close(ignored);
    udp_.stop();
    heap_trimmer_.stop();
    if (http_)
        http_->stop();
    stopping_ = true;
    // Unregister first, then close: readers elsewhere see the ports go away cleanly. The names are
    // copied: clients that leave while this waits for the name server close their ports, which
    // erases them from the router's map (looping over the map itself here once spun for good).
    std::vector<std::string> registered;
    for (const auto& [name, port] : router_.ports())
        registered.push_back(name);
    const auto unregister_deadline = std::chrono::steady_clock::now() + unregister_grace;
    for (const auto& name : registered) {
        const auto left = unregister_deadline - std::chrono::steady_clock::now();
        if (!names_ || !names_->connected() || left <= decltype(left)::zero())
            break;
        co_await names_->unregister_port(name, left);
    }
    std::vector<std::shared_ptr<Port>> ports;
    for (const auto& [name, port] : router_.ports())
        ports.push_back(port);
    for (auto& port : ports)
        forget_port(port);
    for (auto& [id, weak] : sessions_) {
        if (auto session = weak.lock())
            session->close_when_drained();
    }
    if (names_)
        names_->stop();
    if (embedded_names_)
        embedded_names_->stop();
    // Links and sessions flush what was written; wait for them, but not forever.
    const auto deadline = std::chrono::steady_clock::now() + shutdown_grace;
    auto busy = [this] {
        std::erase_if(links_, [](const std::weak_ptr<Peer>& link) {
            auto peer = link.lock();
            return !peer || peer->closed();
        });
        return !sessions_.empty() || !links_.empty();
    };
    // Monitors get a second of it to hand on what they hold; a slow script gets no more.
    const auto monitors_deadline = std::chrono::steady_clock::now() + monitors_grace;
    bool monitors_closed = false;
    while ((busy() || !monitors_closed) && std::chrono::steady_clock::now() < deadline) {
        if (!monitors_closed &&
            (scripts_->in_flight() == 0 || std::chrono::steady_clock::now() >= monitors_deadline)) {
            scripts_->close_stages();
            monitors_closed = true;
            continue;
        }
        asio::steady_timer tick(io_, std::chrono::milliseconds(20));
        co_await tick.async_wait(use_nothrow);
    }
    scripts_->close_stages();
    io_.stop();
}

}  // namespace plexus::daemon
