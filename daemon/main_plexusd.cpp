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

#include "daemon.hpp"
#include "plexus/proto/datagram.hpp"
#include "plexus/proto/defaults.hpp"
#include "plexus/proto/discovery.hpp"
#include "trust.hpp"

namespace {

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

/// The udp carrier's keys of the config file, checked together: a value out of range is refused
/// with the range, so that a daemon never runs with a carrier that could not carry its own limit.
void apply_udp_config(const std::string& path, const nlohmann::json& json,
                      plexus::daemon::DaemonConfig& config) {
    auto& udp = config.udp;
    udp.fragment_bytes = json.value("udp_fragment_bytes", udp.fragment_bytes);
    // Unless it is given, the largest udp message follows a smaller frame limit down.
    udp.max_message = json.value("udp_max_message", std::min(udp.max_message, config.max_frame));
    udp.reassembly_bytes = json.value("udp_reassembly_bytes", udp.reassembly_bytes);
    udp.reassembly_timeout =
        std::chrono::milliseconds(json.value("udp_timeout_ms", udp.reassembly_timeout.count()));
    const std::string where = "config " + path + ": ";
    // 256 keeps the header's share of a datagram small; 65,000 plus the largest header fits the
    // 65,507 bytes of an IPv4 UDP payload.
    if (udp.fragment_bytes < 256 || udp.fragment_bytes > 65000) {
        throw std::runtime_error(where + "udp_fragment_bytes must be between 256 and 65000, not " +
                                 std::to_string(udp.fragment_bytes));
    }
    // A message the carrier takes must reach a reader in one frame.
    if (udp.max_message < 1 || udp.max_message > config.max_frame) {
        throw std::runtime_error(where + "udp_max_message must be between 1 and max_frame (" +
                                 std::to_string(config.max_frame) + "), not " +
                                 std::to_string(udp.max_message));
    }
    const auto fragments = plexus::proto::fragment_count(udp.max_message, udp.fragment_bytes);
    if (fragments > plexus::proto::max_datagram_fragments) {
        throw std::runtime_error(where + "udp_max_message " + std::to_string(udp.max_message) +
                                 " would be cut into " + std::to_string(fragments) +
                                 " fragments of udp_fragment_bytes " + std::to_string(udp.fragment_bytes) +
                                 ", more than a datagram may say (" +
                                 std::to_string(plexus::proto::max_datagram_fragments) +
                                 "): lower it or raise udp_fragment_bytes");
    }
    // Less than one largest message of room and such a message could never be put together.
    if (udp.reassembly_bytes < udp.max_message) {
        throw std::runtime_error(where + "udp_reassembly_bytes (" + std::to_string(udp.reassembly_bytes) +
                                 ") must be at least udp_max_message (" + std::to_string(udp.max_message) +
                                 ")");
    }
    if (udp.reassembly_timeout.count() < 10 || udp.reassembly_timeout.count() > 600000) {
        throw std::runtime_error(where + "udp_timeout_ms must be between 10 and 600000, not " +
                                 std::to_string(udp.reassembly_timeout.count()));
    }
}

/// Reads the optional JSON config; command-line flags given explicitly win over it.
void apply_config_file(const std::string& path, plexus::daemon::DaemonConfig& config) {
    std::ifstream in(path);
    if (!in)
        throw std::runtime_error("cannot open config file " + path);
    auto json = nlohmann::json::parse(in, nullptr, true, true);
    static const std::set<std::string> known{"names",
                                             "max_frame",
                                             "default_capacity",
                                             "link_capacity",
                                             "queue_bytes",
                                             "shm_region_bytes",
                                             "shm_total_bytes",
                                             "names_grace_ms",
                                             "names_state",
                                             "scripts",
                                             "log_level",
                                             "monitor_memory_bytes",
                                             "monitor_budget_ms",
                                             "monitor_quarantine_after",
                                             "udp_fragment_bytes",
                                             "udp_max_message",
                                             "udp_reassembly_bytes",
                                             "udp_timeout_ms"};
    for (const auto& [key, value] : json.items()) {
        if (!known.contains(key))
            throw std::runtime_error("config " + path + ": unknown key '" + key + "'");
    }
    config.max_frame = json.value("max_frame", config.max_frame);
    config.default_capacity = json.value("default_capacity", config.default_capacity);
    config.link_capacity = json.value("link_capacity", config.link_capacity);
    config.queue_bytes = json.value("queue_bytes", config.queue_bytes);
    config.shm_region_bytes = json.value("shm_region_bytes", config.shm_region_bytes);
    config.shm_total_bytes = json.value("shm_total_bytes", config.shm_total_bytes);
    if (config.shm_region_bytes != 0 && config.shm_region_bytes < 1024 * 1024)
        throw std::runtime_error("config " + path + ": shm_region_bytes must be 0 (off) or at least 1048576");
    config.names_grace = std::chrono::milliseconds(json.value("names_grace_ms", config.names_grace.count()));
    config.names_state = json.value("names_state", config.names_state);
    for (const auto& dir : json.value("scripts", std::vector<std::string>{}))
        config.script_dirs.push_back(dir);
    auto& monitors = config.monitors;
    monitors.limits.memory_bytes = json.value("monitor_memory_bytes", monitors.limits.memory_bytes);
    monitors.limits.budget =
        std::chrono::milliseconds(json.value("monitor_budget_ms", monitors.limits.budget.count()));
    monitors.quarantine_after = json.value("monitor_quarantine_after", monitors.quarantine_after);
    if (monitors.limits.memory_bytes < 256 * 1024 || monitors.limits.budget.count() < 1 ||
        monitors.quarantine_after < 1) {
        throw std::runtime_error("config " + path +
                                 ": monitor_memory_bytes must be at least 262144, monitor_budget_ms and "
                                 "monitor_quarantine_after at least 1");
    }
    apply_udp_config(path, json, config);
    if (json.contains("log_level"))
        spdlog::set_level(spdlog::level::from_str(json["log_level"].get<std::string>()));
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
    app.add_option("--socket", socket, "Unix socket for local clients (env PLEXUS_SOCKET)")
        ->capture_default_str();
    app.add_option("--node", node, "this daemon's node name, unique among daemons")->capture_default_str();
    app.add_option("--scripts", config.script_dirs, "directory of monitor scripts (repeatable)");
    app.add_option("--config", config_file,
                   "JSON config file (max_frame, default_capacity, link_capacity, monitor_memory_bytes, "
                   "monitor_budget_ms, monitor_quarantine_after, udp_fragment_bytes, udp_max_message, "
                   "udp_reassembly_bytes, udp_timeout_ms, ...)");
    app.add_option("--ready-file", config.ready_file,
                   "write a JSON line (node, address, socket, names, pid) here once serving and registered");
    std::string secret_file;
    app.add_option(
        "--secret-file", secret_file,
        "the deployment secret (env PLEXUS_SECRET_FILE): a file only its owner may read, 16+ bytes, "
        "the same on every machine; TCP peers must prove they hold it and datagrams carry a MAC");
    app.add_flag("--insecure", config.insecure,
                 "listen beyond loopback without a secret (anyone who reaches the daemon can use it)");
    app.add_option("--log-level", log_level, "trace, debug, info, warn, error")->capture_default_str();
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }
    try {
        spdlog::set_level(spdlog::level::from_str(log_level));
        if (!config_file.empty())
            apply_config_file(config_file, config);
        auto found = embedded ? plexus::proto::choose_names(names, config_file, [] { return std::nullopt; })
                              : plexus::proto::find_names(names, config_file);
        if (!found)
            throw std::runtime_error(found.error().message);
        config.names = endpoint_or_throw(found->address, "--names");
        spdlog::info("name server {} ({})", found->address, found->how());
        config.listen = endpoint_or_throw(listen, "--listen");
        config.embedded_names = embedded;
        if (!names_state.empty())
            config.names_state = names_state;
        config.socket_path = socket;
        config.node = node;
        auto secret = plexus::daemon::load_deployment_secret(secret_file);
        if (!secret)
            throw std::runtime_error(secret.error().message);
        config.secret = *secret;
        std::vector<std::string> listening{config.listen.host};
        if (embedded)
            listening.push_back(config.names.host);
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
