#include "config_file.hpp"
#include "plexus/proto/rings.hpp"

#include <algorithm>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <stdexcept>
#include <type_traits>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "plexus/proto/endpoint.hpp"

#include "plexus/proto/datagram.hpp"

namespace plexus::daemon {

namespace {

/// The value of a numeric key, `fallback` when it is absent. json.value() would convert any
/// number to T without a word: 1e300 into a size_t is undefined behaviour, -1 becomes
/// 18446744073709551615 (a max_frame of 16 EiB), 4294967297 a uint32 of 1. A value that is not a
/// whole number within T's range is refused, naming the key.
template <typename T>
T whole_number(const nlohmann::json& json, const char* key, T fallback, const std::string& path) {
    const auto it = json.find(key);
    if (it == json.end())
        return fallback;
    constexpr auto least = std::numeric_limits<T>::min();
    constexpr auto most = std::numeric_limits<T>::max();
    const auto refuse = [&] {
        throw std::runtime_error("config " + path + ": " + key + " must be a whole number from " +
                                 std::to_string(least) + " to " + std::to_string(most) + ", not " +
                                 it->dump());
    };
    if (it->is_number_unsigned()) {
        const auto value = it->get<std::uint64_t>();
        if (value > static_cast<std::uint64_t>(most))
            refuse();
        return static_cast<T>(value);
    }
    if (it->is_number_integer()) {  // negative: nlohmann keeps non-negative integers unsigned
        const auto value = it->get<std::int64_t>();
        if (std::is_unsigned_v<T> || value < static_cast<std::int64_t>(least))
            refuse();
        return static_cast<T>(value);
    }
    refuse();
    return fallback;  // not reached
}

/// The udp carrier's keys of the config file, checked together: a value out of range is refused
/// with the range, so that a daemon never runs with a carrier that could not carry its own limit.
void apply_udp_config(const std::string& path, const nlohmann::json& json, DaemonConfig& config) {
    auto& udp = config.udp;
    udp.fragment_bytes = whole_number(json, "udp_fragment_bytes", udp.fragment_bytes, path);
    // Unless it is given, the largest udp message follows a smaller frame limit down.
    udp.max_message =
        whole_number(json, "udp_max_message", std::min(udp.max_message, config.max_frame), path);
    udp.reassembly_bytes = whole_number(json, "udp_reassembly_bytes", udp.reassembly_bytes, path);
    udp.reassembly_timeout =
        std::chrono::milliseconds(whole_number(json, "udp_timeout_ms", udp.reassembly_timeout.count(), path));
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
    const auto fragments = proto::fragment_count(udp.max_message, udp.fragment_bytes);
    if (fragments > proto::max_datagram_fragments) {
        throw std::runtime_error(
            where + "udp_max_message " + std::to_string(udp.max_message) + " would be cut into " +
            std::to_string(fragments) + " fragments of udp_fragment_bytes " +
            std::to_string(udp.fragment_bytes) + ", more than a datagram may say (" +
            std::to_string(proto::max_datagram_fragments) + "): lower it or raise udp_fragment_bytes");
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

}  // namespace

void apply_config_text(const std::string& path, std::string_view text, DaemonConfig& config) {
    // Comments are allowed: a config file is written by hand.
    auto json = nlohmann::json::parse(text, nullptr, true, true);
    static const std::set<std::string> known{"names",
                                             "advertise",
                                             "http",
                                             "http_max_connections",
                                             "http_read_timeout_ms",
                                             "http_write_timeout_ms",
                                             "http_stream_backlog_bytes",
                                             "max_frame",
                                             "default_capacity",
                                             "link_capacity",
                                             "queue_bytes",
                                             "shm_region_bytes",
                                             "shm_total_bytes",
                                             "shm_ring_bytes",
                                             "shm_ring_spin_us",
                                             "names_grace_ms",
                                             "handshake_timeout_ms",
                                             "peer_connections",
                                             "peer_handshakes",
                                             "peer_failed_proofs",
                                             "names_state",
                                             "scripts",
                                             "monitor_libs",
                                             "log_level",
                                             "monitor_memory_bytes",
                                             "monitor_budget_ms",
                                             "monitor_quarantine_after",
                                             "monitor_inline_cost_us",
                                             "udp_fragment_bytes",
                                             "udp_max_message",
                                             "udp_reassembly_bytes",
                                             "udp_timeout_ms"};
    if (!json.is_object())
        throw std::runtime_error("config " + path + ": expected a JSON object of settings, not " +
                                 json.type_name());
    for (const auto& [key, value] : json.items()) {
        if (!known.contains(key))
            throw std::runtime_error("config " + path + ": unknown key '" + key + "'");
    }
    config.max_frame = whole_number(json, "max_frame", config.max_frame, path);
    config.default_capacity = whole_number(json, "default_capacity", config.default_capacity, path);
    config.link_capacity = whole_number(json, "link_capacity", config.link_capacity, path);
    config.queue_bytes = whole_number(json, "queue_bytes", config.queue_bytes, path);
    config.shm_region_bytes = whole_number(json, "shm_region_bytes", config.shm_region_bytes, path);
    config.shm_total_bytes = whole_number(json, "shm_total_bytes", config.shm_total_bytes, path);
    if (config.shm_region_bytes != 0 && config.shm_region_bytes < 1024 * 1024)
        throw std::runtime_error("config " + path + ": shm_region_bytes must be 0 (off) or at least 1048576");
    config.shm_ring_bytes = whole_number(json, "shm_ring_bytes", config.shm_ring_bytes, path);
    config.ring_spin =
        std::chrono::microseconds(whole_number(json, "shm_ring_spin_us", config.ring_spin.count(), path));
    if (config.ring_spin.count() < 0 || config.ring_spin.count() > 1000)
        throw std::runtime_error("config " + path + ": shm_ring_spin_us must be between 0 and 1000");
    if (config.shm_ring_bytes != 0 && (config.shm_ring_bytes < proto::RingLayout::min_ring_bytes ||
                                       config.shm_ring_bytes > proto::RingLayout::max_ring_bytes ||
                                       (config.shm_ring_bytes & (config.shm_ring_bytes - 1)) != 0)) {
        throw std::runtime_error("config " + path +
                                 ": shm_ring_bytes must be 0 (off) or a power of two from 65536 to 16777216");
    }
    config.names_grace =
        std::chrono::milliseconds(whole_number(json, "names_grace_ms", config.names_grace.count(), path));
    config.handshake_timeout = std::chrono::milliseconds(
        whole_number(json, "handshake_timeout_ms", config.handshake_timeout.count(), path));
    if (config.handshake_timeout.count() < 100 || config.handshake_timeout.count() > 3'600'000)
        throw std::runtime_error("config " + path + ": handshake_timeout_ms must be between 100 and 3600000");
    auto& peers = config.peer_limits;
    peers.connections = whole_number(json, "peer_connections", peers.connections, path);
    // Unless given, the handshakes' bound follows fewer connections down.
    peers.handshakes =
        whole_number(json, "peer_handshakes", std::min(peers.handshakes, peers.connections), path);
    peers.failed_proofs = whole_number(json, "peer_failed_proofs", peers.failed_proofs, path);
    if (peers.connections < 1 || peers.connections > 1'000'000)
        throw std::runtime_error("config " + path + ": peer_connections must be between 1 and 1000000");
    if (peers.handshakes < 1 || peers.handshakes > peers.connections)
        throw std::runtime_error("config " + path +
                                 ": peer_handshakes must be between 1 and peer_connections (" +
                                 std::to_string(peers.connections) + ")");
    if (peers.failed_proofs > 1000)
        throw std::runtime_error("config " + path +
                                 ": peer_failed_proofs must be between 0 (no limit) and 1000");
    config.names_state = json.value("names_state", config.names_state);
    config.advertise = json.value("advertise", config.advertise);
    if (json.contains("http")) {
        const auto& http = json["http"];
        if (!http.is_string())
            throw std::runtime_error("config " + path +
                                     ": http must be \"HOST:PORT\", e.g. \"127.0.0.1:8080\"");
        auto endpoint = proto::parse_endpoint(http.get<std::string>());
        if (!endpoint)
            throw std::runtime_error("config " + path + ": http: " + endpoint.error().message);
        config.http.listen = *endpoint;
    }
    auto& http = config.http;
    http.max_connections = whole_number(json, "http_max_connections", http.max_connections, path);
    http.read_timeout = std::chrono::milliseconds(
        whole_number(json, "http_read_timeout_ms", http.read_timeout.count(), path));
    http.write_timeout = std::chrono::milliseconds(
        whole_number(json, "http_write_timeout_ms", http.write_timeout.count(), path));
    http.stream_backlog_bytes =
        whole_number(json, "http_stream_backlog_bytes", http.stream_backlog_bytes, path);
    if (http.max_connections < 1 || http.read_timeout.count() < 100 || http.write_timeout.count() < 100 ||
        http.stream_backlog_bytes < 4096)
        throw std::runtime_error(
            "config " + path +
            ": http_max_connections must be at least 1, http_read_timeout_ms and "
            "http_write_timeout_ms at least 100, http_stream_backlog_bytes at least 4096");
    for (const auto& dir : json.value("scripts", std::vector<std::string>{}))
        config.script_dirs.push_back(dir);
    for (const auto& dir : json.value("monitor_libs", std::vector<std::string>{}))
        config.monitor_lib_dirs.push_back(dir);
    auto& monitors = config.monitors;
    monitors.limits.memory_bytes =
        whole_number(json, "monitor_memory_bytes", monitors.limits.memory_bytes, path);
    monitors.limits.budget = std::chrono::milliseconds(
        whole_number(json, "monitor_budget_ms", monitors.limits.budget.count(), path));
    monitors.quarantine_after =
        whole_number(json, "monitor_quarantine_after", monitors.quarantine_after, path);
    monitors.inline_cost_limit = std::chrono::microseconds(
        whole_number(json, "monitor_inline_cost_us", monitors.inline_cost_limit.count(), path));
    if (monitors.inline_cost_limit.count() > 1'000'000)
        throw std::runtime_error("config " + path +
                                 ": monitor_inline_cost_us must be at most 1000000 (0: never inline)");
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

void apply_config_file(const std::string& path, DaemonConfig& config) {
    std::ifstream in(path);
    if (!in)
        throw std::runtime_error("cannot open config file " + path);
    const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    apply_config_text(path, text, config);
}

}  // namespace plexus::daemon
