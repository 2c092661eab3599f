// plexus-bench hosts --calls: call round trips (request/reply, issue 29) from a caller on host 1's
// daemon to a server on host 2's, against the relay floor with the same hops (caller -> relay on
// host 1 -> relay on host 2 -> server, and back) and a direct TCP ping-pong between the hosts.
#include <cmath>
#include <cstdio>
#include <iostream>

#include <nlohmann/json.hpp>

#include "floor_measurements.hpp"
#include "hosts_deployment.hpp"
#include "hosts_floor.hpp"
#include "hosts_scenario.hpp"
#include "plexus_measurements.hpp"
#include "process_stats.hpp"
#include "report.hpp"

namespace plexus::bench {

namespace {

constexpr int caller_host = 1;
constexpr int server_host = 2;

struct Size {
    std::size_t bytes;
    std::size_t calls;        ///< per run
    std::size_t quick_calls;  ///< per run with --quick
};
// Enough calls for a stable p99 at 64 B, about 50 MiB each way at 64 KiB, about 50 at 1 MiB.
constexpr Size sizes[] = {{64, 2000, 200}, {64 << 10, 800, 50}, {1 << 20, 50, 10}};

void print_json(const std::vector<Row>& rows) {
    for (const auto& row : rows) {
        for (const auto& [system, run] : row.systems) {
            std::cout << nlohmann::ordered_json{{"system", system},
                                                {"scenario", "hosts_calls"},
                                                {"carrier", row.carrier},
                                                {"size", row.size},
                                                {"count", row.count},
                                                {"p50_us", rounded(run.p50_us)},
                                                {"p99_us", rounded(run.p99_us)},
                                                {"mean_us", rounded(run.mean_us)},
                                                {"msgs_per_s", rounded(run.msgs_per_s)},
                                                {"cpu_us_per_msg", rounded(run.cpu_us_per_msg)}}
                             .dump()
                      << '\n';
        }
    }
}

void print_table(const HostsOptions& options, const std::vector<Row>& rows) {
    std::printf(
        "Calls across hosts: a caller on host 1's plexusd calls a port served on host 2's (tcp, deployment\n"
        "secret on), one call at a time, the request echoed; whole round trips in us, median of %d runs.\n"
        "relay floor: caller -> relay (host 1) -> relay (host 2) -> server and back, Plexus's hops;\n"
        "tcp floor: a direct TCP ping-pong between the two hosts, no broker.\n\n",
        options.repeat);
    std::printf("  %-7s %6s %10s %10s %10s %10s %10s %8s %8s %10s  %s\n", "size", "calls", "plexus p50",
                "p99", "mean", "relay p50", "p99", "p50 x", "p99 x", "tcp p50", "target p50 <= 1.5x relay");
    for (const auto& row : rows) {
        const auto& p = *row.find("plexus");
        const auto& r = *row.find("relay_floor");
        const auto& f = *row.find("floor");
        const double x = ratio(p.p50_us, r.p50_us);
        std::printf("  %-7s %6zu %10.1f %10.1f %10.1f %10.1f %10.1f %8.2f %8.2f %10.1f  %s\n",
                    size_text(row.size).c_str(), row.count, p.p50_us, p.p99_us, p.mean_us, r.p50_us, r.p99_us,
                    x, ratio(p.p99_us, r.p99_us), f.p50_us, x <= 1.5 ? "met" : "missed");
    }
    std::fflush(stdout);
}

}  // namespace

int run_hosts_calls(const HostsOptions& options, const HostsNetwork& network, const TempDir& dir) {
    const std::string load_before = load_average();
    const std::string secret = write_secret(dir);
    const Deployment deployment(network, dir, options, "c", secret, {caller_host, server_host}, 10120,
                                "239.255.83.0/24", 10122);
    const auto plexus = deployment.pair(caller_host, server_host);
    std::vector<Row> rows;
    for (const auto& size : sizes) {
        const Options o = options_for(size.bytes, options.quick ? size.quick_calls : size.calls, "tcp");
        auto calls = plexus_calls(*plexus, o);
        // A relay pairs the first two clients it sees: a pair of relays per size.
        RelayPair relays(network, dir, "calls-" + std::to_string(size.bytes), caller_host, server_host);
        auto relayed = floor_round_trip(relays.topology(), o);
        auto direct = floor_round_trip_between(tcp_floor_ends(network, caller_host, server_host), o);
        rows.push_back(
            alternate({"calls", "tcp", size.bytes, latency_count(o), {}},
                      {{"plexus", calls.get()}, {"relay_floor", relayed.get()}, {"floor", direct.get()}},
                      options.repeat));
    }
    if (options.json) {
        print_json(rows);
    } else {
        print_table(options, rows);
        std::printf("\nload average (1, 5, 15 min) before: %s, after: %s\n", load_before.c_str(),
                    load_average().c_str());
    }
    return 0;
}

}  // namespace plexus::bench
