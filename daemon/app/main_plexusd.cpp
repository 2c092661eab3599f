// plexusd: the node daemon. Parses the command line and config, then runs the daemon.
#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <iostream>
#include <set>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "config_file.hpp"
#include "daemon.hpp"
#include "number_options.hpp"
#include "plexus/proto/datagram.hpp"
#include "plexus/proto/defaults.hpp"
#include "plexus/proto/discovery.hpp"
#include "trust.hpp"

namespace {

/// More monitor threads than this is a typo, not a machine: each is a thread with its own stack.
constexpr std::uint64_t most_monitor_threads = 1024;
/// Data threads beyond this are a typo: each costs every control-thread handler a lock.
constexpr std::uint64_t most_data_threads = 64;

std::string host_name() {
    char buffer[256] = {};
    if (::gethostname(buffer, sizeof buffer - 1) != 0 || buffer[0] == '\0')
        return "node";
    return buffer;
}

plexus::proto::Endpoint endpoint_or_throw(const std::string& text, const char* option) {
    auto parsed = plexus::proto::parse_endpoint(text);
    if (!parsed)
        throw std::runtime_error(std::string(option) + ": " + parsed.error().message);
    return *parsed;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{
        "plexusd: the Plexus node daemon. Hosts the ports of local components, connects them "
        "to each other and to other daemons, and moves their data."};
    std::optional<std::string> names;
    std::string listen = "127.0.0.1:0";
    std::string socket = plexus::proto::default_socket();
    std::string node = host_name();
    std::string config_file;
    std::string names_state;
    std::string log_level = "info";
    bool embedded = false;
    plexus::daemon::DaemonConfig config;
    app.add_option("--names", names,
                   "name server HOST:PORT (else env PLEXUS_NAMES, the config file's \"names\", multicast "
                   "discovery, 127.0.0.1:10100; with --embedded-names: where to serve it, no discovery)");
    app.add_flag("--embedded-names", embedded, "also serve the name server, at the --names address");
    app.add_option("--names-state", names_state,
                   "with --embedded-names: file keeping persistent connections");
    app.add_option("--listen", listen, "TCP HOST:PORT for other daemons and remote clients (port 0: any)")
        ->capture_default_str();
    app.add_option("--advertise", config.advertise,
                   "the HOST other machines reach this daemon at (config \"advertise\"); by default the "
                   "--listen host, or, when that is 0.0.0.0 or ::, the address the name server sees "
                   "this daemon come from");
    app.add_option("--socket", socket, "Unix socket for local clients (env PLEXUS_SOCKET)")
        ->capture_default_str();
    auto* node_option = app.add_option("--node", node, "this daemon's node name, unique among daemons")
                            ->capture_default_str();
    app.add_option("--scripts", config.script_dirs, "directory of monitor scripts (repeatable)");
    app.add_option("--monitor-libs", config.monitor_lib_dirs,
                   "directory of compiled monitors, type.so (repeatable); plugins are trusted code that "
                   "runs inside this daemon");
    app.add_option("--monitor-threads", config.monitor_threads,
                   "threads that run port monitors, so that a slow script delays only its own "
                   "connection (0: one per core)")
        ->transform(plexus::daemon::whole_number(0, most_monitor_threads))
        ->capture_default_str();
    app.add_option("--threads", config.threads,
                   "threads that move data: 1, one thread does everything; N > 1, N data threads "
                   "beside the control thread, local clients shared among them (a connection keeps "
                   "its order; one between two threads costs a copy and a hand-over)")
        ->transform(plexus::daemon::whole_number(1, most_data_threads))
        ->capture_default_str();
    bool no_inline_monitors = false;
    app.add_flag("--no-inline-monitors", no_inline_monitors,
                 "run every monitor on the worker threads; by default a monitor that costs under 10 us a "
                 "message (config monitor_inline_cost_us) runs on the daemon's thread, which saves two "
                 "thread wake-ups per message (docs/MONITORS.md)");
    app.add_option("--config", config_file,
                   "JSON config file (max_frame, default_capacity, link_capacity, monitor_memory_bytes, "
                   "monitor_budget_ms, monitor_quarantine_after, monitor_inline_cost_us, udp_fragment_bytes, "
                   "udp_max_message, "
                   "udp_reassembly_bytes, udp_timeout_ms, ...)");
    app.add_option("--ready-file", config.ready_file,
                   "write a JSON line (node, address, socket, names, pid) here once serving and registered");
    std::string secret_file;
    app.add_option(
        "--secret-file", secret_file,
        "the deployment secret (env PLEXUS_SECRET_FILE): a file only its owner may read, 16+ bytes, "
        "the same on every machine; every TCP link is TLS 1.3 keyed by it, udp/mcast datagrams are "
        "sealed (AES-GCM, a key per stream), and discovery takes only a name server that holds it");
    std::string identity;
    app.add_option("--identity", identity,
                   "this node's identity directory (`plexus pki issue NODE`; env PLEXUS_IDENTITY): TCP links "
                   "are then mutual TLS with certificates, and the node is the one its certificate names "
                   "(--node may be left out); needs the secret too");
    std::string permissions_file;
    app.add_option("--permissions", permissions_file,
                   "a permissions file (JSON rules by node and local user, docs/SECURITY.md): who may open, "
                   "write, read, connect or attach monitors to which ports; what no rule allows is refused "
                   "(exit 4 for the asker), logged once and counted (stats: permission_refusals). SIGHUP "
                   "reads it again. Without it, everyone may do everything");
    std::optional<std::string> http;
    app.add_option("--http", http,
                   "serve the web page of the whole system, its JSON views, live stream and Prometheus "
                   "/metrics at HOST:PORT (config \"http\"; off by default; port 0: any). Beyond "
                   "loopback only with the secret (browsers then need `plexus web --token`) or "
                   "--insecure (docs/WEB.md)");
    app.add_flag("--insecure", config.insecure,
                 "listen beyond loopback without a secret (anyone who reaches the daemon can use it)");
    // spdlog reads a name it does not know as "off": a typo would silence the daemon.
    app.add_option("--log-level", log_level, "trace, debug, info, warn, error")
        ->capture_default_str()
        ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }
    try {
        spdlog::set_level(spdlog::level::from_str(log_level));
        if (!config_file.empty())
            plexus::daemon::apply_config_file(config_file, config);
        // The secret first: discovery takes only a name server that proves it holds it.
        auto secret = plexus::daemon::load_deployment_secret(secret_file, identity);
        if (!secret)
            throw std::runtime_error(secret.error().message);
        config.secret = *secret;
        auto permissions = plexus::daemon::load_permissions(permissions_file);
        if (!permissions)
            throw std::runtime_error(permissions.error().message);
        config.permissions = *permissions;
        if (const auto* certified = config.secret ? config.secret->identity() : nullptr) {
            const std::string& named = certified->subject().name;
            if (node_option->count() > 0 && node != named)
                throw std::runtime_error("--node " + node + ": this node's identity (" +
                                         certified->directory() + ") is that of node '" + named + "'");
            if (embedded)
                throw std::runtime_error(
                    "--embedded-names with --identity: a name server needs a name server's "
                    "identity; run plexus-names --identity with one (`plexus pki issue NAME "
                    "--names`)");
            node = named;
        }
        const auto* proving = config.secret ? &*config.secret : nullptr;
        auto found =
            embedded ? plexus::proto::choose_names(names, config_file, [] { return std::nullopt; })
                     : plexus::proto::find_names(names, config_file, std::chrono::milliseconds(600), proving);
        if (!found)
            throw std::runtime_error(found.error().message);
        config.names = endpoint_or_throw(found->address, "--names");
        spdlog::info("name server {} ({})", found->address, found->how());
        config.listen = endpoint_or_throw(listen, "--listen");
        if (!config.advertise.empty()) {
            endpoint_or_throw(plexus::proto::Endpoint{config.advertise, 1}.text(), "--advertise");
            boost::system::error_code unspecified;
            if (auto host = boost::asio::ip::make_address(config.advertise, unspecified);
                !unspecified && host.is_unspecified())
                throw std::runtime_error("--advertise " + config.advertise +
                                         ": an address other machines can connect to, not a wildcard");
        }
        config.embedded_names = embedded;
        if (no_inline_monitors)
            config.monitors.inline_cost_limit = std::chrono::microseconds(0);
        if (!names_state.empty())
            config.names_state = names_state;
        config.socket_path = socket;
        config.node = node;
        std::vector<std::string> listening{config.listen.host};
        if (embedded)
            listening.push_back(config.names.host);
        if (http)
            config.http.listen = endpoint_or_throw(*http, "--http");
        if (config.http.listen)
            listening.push_back(config.http.listen->host);
        if (auto allowed = plexus::daemon::check_listening(listening, config.secret.has_value(),
                                                           config.insecure, "plexusd");
            !allowed) {
            throw std::runtime_error(allowed.error().message);
        }
    } catch (const std::exception& e) {
        std::cerr << "plexusd: " << e.what() << '\n';
        return 2;
    }
    // Large frames come and go at a high rate: keep freed memory in the heap instead of returning it
    // to the kernel (and page-faulting it back in on the next frame). Memory is still bounded by
    // the queues' byte limits; what is kept is at most the peak in use.
    ::mallopt(M_MMAP_THRESHOLD, static_cast<int>(config.max_frame + 4096));
    ::mallopt(M_TRIM_THRESHOLD, 256 * 1024 * 1024);
    // Every client is a descriptor, and so is every shared-memory region; region descriptors sent
    // to clients and not yet read count against this limit too. The soft limit is often 1,024:
    // raise it to the hard limit, as servers do.
    rlimit files{};
    if (::getrlimit(RLIMIT_NOFILE, &files) == 0 && files.rlim_cur < files.rlim_max) {
        files.rlim_cur = files.rlim_max;
        ::setrlimit(RLIMIT_NOFILE, &files);
    }
    boost::asio::io_context io(1);
    plexus::daemon::Daemon daemon(io, config);
    return daemon.run();
}
