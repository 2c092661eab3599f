#pragma once
// What the command line asks for.

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

namespace plexus::bench {

struct Options {
    std::size_t size = 64;     ///< payload bytes per message
    int hops = 1;              ///< 1: one daemon (relay); 2: two, linked by tcp
    std::size_t count = 0;     ///< messages (throughput) or round trips (latency) per run; 0: by size
    int repeat = 5;            ///< runs per system; the median of each figure is reported
    bool json = false;         ///< one JSON object per line instead of a table
    std::size_t capacity = 0;  ///< reader queue length asked of plexusd; 0: the daemon's default
    std::string plexusd;       ///< path of the daemon binary
    std::size_t ports = 1000;  ///< memory: ports to open
    /// streams: how many independent streams each row runs, and the clients they are spread over.
    std::vector<int> streams{1, 10, 100, 1000};
    int stream_clients = 16;
    /// streams: plexusd's --threads for each set of rows (one daemon each, runs alternating).
    std::vector<int> daemon_threads{1};
    bool empty_accept = false;  ///< monitor: also run an accept that returns true without reading msg
    /// latency: Plexus writes loans (Port::loan, send_loan) and reads views (read_view) instead of
    /// write/read: zero-copy on one machine. Neither side touches the payload past its first 64 bytes.
    bool loans = false;
    /// Carrier of the connections latency and throughput make ("": the daemon's choice). A
    /// non-empty one also prefixes their port names ("/bench/udp-ping"), so that scenarios on
    /// different carriers can share daemons.
    std::string carrier;
    /// Prefix of the port names instead of the carrier's ("monitored" -> "/bench/monitored-ping").
    std::string port_tag;
    /// web: idle TCP connections kept open to the web endpoint during the runs with it.
    int idle_connections = 50;
    /// web: messages per throughput run (0: by size, as `throughput`); --count is the latency's.
    std::size_t stream_count = 0;
    /// web: the stream's cost: the `plexus` CLI, the application file it brings up (the fetch
    /// robot), the seconds of each CPU window and the windows per variant.
    std::string plexus_cli;
    std::string app_file;
    double window_s = 20;
    int cost_repeat = 3;
    /// record: where the recordings and dd's files go ("": a fresh directory under /tmp).
    std::string record_dir;
    /// record: 1 MiB messages per recording-throughput run.
    std::size_t record_mib = 256;
    /// record: rounds of writes in the what-if recording (each 3 or 4 messages, 200 us apart).
    int what_if_rounds = 16000;
    /// record: the monitor scripts the what-if recording's Lua carriers name.
    std::string scripts_dir;
    /// record: a plexusd built from the commit before the tap (8cd2c9d), measured alongside.
    std::string baseline_plexusd;
    /// record: which parts to run (throughput, data-path, what-if); empty: all.
    std::vector<std::string> parts;
};

/// Round trips per latency run when --count is not given: about 32 MiB each way, 100 to 10,000.
inline std::size_t latency_count(const Options& options) {
    if (options.count > 0)
        return options.count;
    return std::clamp<std::size_t>((32u << 20) / std::max<std::size_t>(options.size, 1), 100, 10000);
}

/// Messages per throughput run when --count is not given: about 128 MiB, 100 to 200,000.
inline std::size_t throughput_count(const Options& options) {
    if (options.count > 0)
        return options.count;
    return std::clamp<std::size_t>((128u << 20) / std::max<std::size_t>(options.size, 1), 100, 200000);
}

}  // namespace plexus::bench
