// plexus-names: the name server on its own.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "names/name_server.hpp"
#include "number_options.hpp"
#include "plexus/proto/defaults.hpp"
#include "plexus/proto/discovery.hpp"
#include "trust.hpp"

int main(int argc, char** argv) {
    CLI::App app{
        "plexus-names: the Plexus name server. Registers ports and daemons over TCP, answers "
        "look-ups over TCP and UDP on the same port, and keeps persistent connections."};
    std::string listen = plexus::proto::default_names();
    std::string state;
    std::string log_level = "info";
    int grace_ms = 2000;
    std::string ready_file;
    std::string discovery;
    int handshake_timeout_ms = 10000;
    app.add_option("--listen", listen, "HOST:PORT to serve on, TCP and UDP (env PLEXUS_NAMES)")
        ->capture_default_str();
    app.add_option("--state", state, "file that keeps persistent connections across restarts");
    // A day at most: a longer grace keeps a dead daemon's ports (and their names) for good.
    app.add_option("--grace-ms", grace_ms, "how long a vanished daemon's ports stay registered")
        ->transform(plexus::daemon::whole_number(0, 86'400'000))
        ->capture_default_str();
    app.add_option("--handshake-timeout-ms", handshake_timeout_ms,
                   "cut off a TCP peer that has not finished its handshake (TLS with a secret, then hello) "
                   "this long after connecting")
        ->transform(plexus::daemon::whole_number(100, 3'600'000))
        ->capture_default_str();
    app.add_option("--ready-file", ready_file, "write {\"names\": HOST:PORT, \"pid\"} here once serving");
    app.add_option("--discovery", discovery,
                   "multicast GROUP:PORT to answer discovery queries on, or off (env PLEXUS_DISCOVERY; "
                   "default " +
                       std::string(plexus::proto::default_discovery_group) +
                       "; only when listening beyond loopback)");
    std::string mcast_range = "239.255.81.0/24";
    int mcast_port = 10102;
    app.add_option(
           "--mcast-range", mcast_range,
           "multicast groups given to source ports for the mcast carrier, as A.B.C.D/PREFIX (16 to 32)")
        ->capture_default_str();
    app.add_option("--mcast-port", mcast_port, "the UDP port of every mcast group")
        ->transform(plexus::daemon::whole_number(1, 65535))
        ->capture_default_str();
    plexus::daemon::PeerLimitConfig peer_limits;
    app.add_option("--peer-connections", peer_limits.connections,
                   "connections one IP address may hold open at once (more are closed at once, counted in "
                   "ping's peers_refused)")
        ->transform(plexus::daemon::whole_number(1, 1'000'000))
        ->capture_default_str();
    app.add_option("--peer-handshakes", peer_limits.handshakes,
                   "of those, connections not through their handshake yet")
        ->transform(plexus::daemon::whole_number(1, 1'000'000))
        ->capture_default_str();
    app.add_option("--peer-failed-proofs", peer_limits.failed_proofs,
                   "failed proofs of the secret (TLS handshakes) one IP address may make in a minute before "
                   "its connections are refused; 0: no limit")
        ->transform(plexus::daemon::whole_number(0, 1'000'000))
        ->capture_default_str();
    std::string secret_file;
    std::string identity;
    bool insecure = false;
    app.add_option("--secret-file", secret_file,
                   "the deployment secret (env PLEXUS_SECRET_FILE): every TCP link is TLS 1.3 keyed by it");
    std::string permissions_file;
    app.add_option("--permissions", permissions_file,
                   "a permissions file (JSON rules, docs/SECURITY.md): a node may then register only the "
                   "ports a rule lets it \"open\"; refusals are logged once and counted (ping's "
                   "permission_refusals); SIGHUP reads it again");
    app.add_option("--identity", identity,
                   "the name server's identity directory (`plexus pki issue NAME --names`; env "
                   "PLEXUS_IDENTITY): links are then mutual TLS with certificates, and a node may only "
                   "register under the name its certificate gives; needs the secret too");
    app.add_flag("--insecure", insecure, "listen beyond loopback without a secret (anyone may register)");
    // spdlog reads a name it does not know as "off": a typo would silence the daemon.
    app.add_option("--log-level", log_level, "trace, debug, info, warn, error")
        ->capture_default_str()
        ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }
    auto endpoint = plexus::proto::parse_endpoint(listen);
    if (!endpoint) {
        std::cerr << "plexus-names: --listen: " << endpoint.error().message << '\n';
        return 2;
    }
    if (!discovery.empty())
        ::setenv("PLEXUS_DISCOVERY", discovery.c_str(), 1);  // one place reads it: discovery_group()
    auto group = plexus::proto::discovery_group();
    if (!group) {
        std::cerr << "plexus-names: --discovery: " << group.error().message << '\n';
        return 2;
    }
    spdlog::set_level(spdlog::level::from_str(log_level));
    auto secret =
        plexus::daemon::load_deployment_secret(secret_file, identity, plexus::proto::Subject::Kind::names);
    if (!secret) {
        std::cerr << "plexus-names: " << secret.error().message << '\n';
        return 2;
    }
    if (auto allowed =
            plexus::daemon::check_listening({endpoint->host}, secret->has_value(), insecure, "plexus-names");
        !allowed) {
        std::cerr << "plexus-names: " << allowed.error().message << '\n';
        return 2;
    }
    boost::asio::io_context io(1);
    plexus::daemon::names::NameServerConfig config;
    config.listen = *endpoint;
    config.state_file = state;
    config.grace = std::chrono::milliseconds(grace_ms);
    config.discovery = *group;
    config.handshake_timeout = std::chrono::milliseconds(handshake_timeout_ms);
    config.secret = *secret;
    config.peer_limits = peer_limits;
    auto permissions = plexus::daemon::load_permissions(permissions_file);
    if (!permissions) {
        std::cerr << "plexus-names: " << permissions.error().message << '\n';
        return 2;
    }
    config.permissions = *permissions;
    {
        // A.B.C.D/PREFIX inside 224.0.0.0/4, at most 65,536 groups.
        const auto slash = mcast_range.find('/');
        boost::system::error_code ec;
        const auto first = boost::asio::ip::make_address_v4(mcast_range.substr(0, slash), ec);
        int prefix = -1;
        try {
            prefix = slash == std::string::npos ? -1 : std::stoi(mcast_range.substr(slash + 1));
        } catch (const std::exception&) {
        }
        if (ec || !first.is_multicast() || prefix < 16 || prefix > 32) {
            std::cerr << "plexus-names: --mcast-range " << mcast_range
                      << ": expected a multicast A.B.C.D/PREFIX with PREFIX 16 to 32, e.g. 239.255.81.0/24\n";
            return 2;
        }
        const std::uint32_t count = 1u << (32 - prefix);
        config.mcast_first = first.to_uint() & ~(count - 1);
        config.mcast_count = count;
        config.mcast_port = static_cast<std::uint16_t>(mcast_port);
    }
    plexus::daemon::names::NameServer server(io, config);
    if (auto started = server.start(); !started) {
        std::cerr << "plexus-names: " << started.error().message << '\n';
        return 4;
    }
    if (!ready_file.empty()) {
        // Write then rename: whoever polls for the file never reads half of it.
        {
            std::ofstream out(ready_file + ".tmp", std::ios::trunc);
            out << "{\"names\": \"" << server.endpoint().text() << "\", \"pid\": " << ::getpid() << "}\n";
        }
        std::filesystem::rename(ready_file + ".tmp", ready_file);
    }
    boost::asio::signal_set signals(io, SIGINT, SIGTERM);
    signals.async_wait([&](boost::system::error_code, int) {
        server.stop();
        io.stop();
    });
    // SIGHUP reads the permissions file again (and no longer ends the process, as by default).
    boost::asio::signal_set reloads(io, SIGHUP);
    std::function<void()> wait_for_reload = [&] {
        reloads.async_wait([&](boost::system::error_code ec, int) {
            if (ec)
                return;
            plexus::daemon::reload_permissions(server.permissions(), "names: ");
            wait_for_reload();
        });
    };
    wait_for_reload();
    io.run();
    return 0;
}
