#include "config_file.hpp"

#include <algorithm>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "plexus/proto/datagram.hpp"

namespace plexus::daemon {

namespace {

/// The udp carrier's keys of the config file, checked together: a value out of range is refused
/// with the range, so that a daemon never runs with a carrier that could not carry its own limit.
void apply_udp_config(const std::string& path, const nlohmann::json& json,
                      DaemonConfig& config) {
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
    const auto fragments = proto::fragment_count(udp.max_message, udp.fragment_bytes);
    if (fragments > proto::max_datagram_fragments) {
        throw std::runtime_error(where + "udp_max_message " + std::to_string(udp.max_message) +
                                 " would be cut into " + std::to_string(fragments) +
                                 " fragments of udp_fragment_bytes " + std::to_string(udp.fragment_bytes) +
                                 ", more than a datagram may say (" +
                                 std::to_string(proto::max_datagram_fragments) +
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

}  // namespace

void apply_config_text(const std::string& path, std::string_view text, DaemonConfig& config) {
    // Comments are allowed: a config file is written by hand.
    auto json = nlohmann::json::parse(text, nullptr, true, true);
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


void apply_config_file(const std::string& path, DaemonConfig& config) {
    std::ifstream in(path);
    if (!in)
        throw std::runtime_error("cannot open config file " + path);
    const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    apply_config_text(path, text, config);
}

}  // namespace plexus::daemon
