#include "scenarios.hpp"

#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <string>

#include "floor_measurements.hpp"
#include "plexus/client.hpp"
#include "plexus_measurements.hpp"
#include "process_stats.hpp"
#include "report.hpp"
#include "run_deadline.hpp"
#include "topology.hpp"

namespace plexus::bench {

namespace {

using Factory = std::function<std::unique_ptr<Measurement>(const Topology&, const Options&)>;

std::string hops_text(int hops) {
    return hops == 1 ? "1 hop" : std::to_string(hops) + " hops";
}

/// Starts both systems, then alternates their runs so that drift on the machine hits both alike.
ScenarioResult compare(const Options& options, const Factory& plexus_factory, const Factory& floor_factory) {
    TempDir dir;
    const auto plexus_topology = Topology::plexus(dir, options.plexusd, options.hops);
    const auto floor_topology = Topology::floor(dir, options.hops);
    ScenarioResult result;
    std::vector<RunResult> plexus_runs;
    std::vector<RunResult> floor_runs;
    {
        RunDeadline deadline;
        const auto plexus = plexus_factory(*plexus_topology, options);
        const auto floor = floor_factory(*floor_topology, options);
        for (int run = 0; run < options.repeat; ++run) {
            RunDeadline per_run;
            plexus_runs.push_back(plexus->run());
            floor_runs.push_back(floor->run());
        }
    }
    result.size = options.size;
    result.plexus = median_of(plexus_runs);
    result.floor = median_of(floor_runs);
    for (const pid_t pid : plexus_topology->pids()) {
        result.plexusd_peak_rss_mb.push_back(static_cast<double>(peak_rss_kib(pid)) / 1024);
    }
    return result;
}

}  // namespace

int run_latency(const Options& options) {
    auto result = compare(options, plexus_latency, floor_latency);
    result.scenario = "latency_" + std::to_string(options.hops) + "hop";
    result.latency_label = "RTT/2";
    result.title = "latency, " + hops_text(options.hops) + ", " + std::to_string(options.size) +
                   " B: " + std::to_string(latency_count(options)) + " round trips per run, median of " +
                   std::to_string(options.repeat) + " runs";
    print(result, options.json);
    return 0;
}

int run_calls(const Options& options) {
    const std::string load_before = load_average();
    auto result = compare(options, plexus_calls, floor_round_trip);
    result.scenario = "calls_" + std::to_string(options.hops) + "hop";
    result.latency_label = "round trip";
    result.messages_label = "messages/s (2 per call)";
    result.show_mean = true;
    result.title = "calls, " + hops_text(options.hops) + ", " + std::to_string(options.size) +
                   " B echoed: " + std::to_string(latency_count(options)) +
                   " calls per run, one at a time, median of " + std::to_string(options.repeat) + " runs";
    print(result, options.json);
    // The machine is shared: a reader of the figures needs to know how busy it was.
    if (!options.json)
        std::printf("  load average (1, 5, 15 min) before: %s, after: %s\n", load_before.c_str(),
                    load_average().c_str());
    return 0;
}

int run_throughput(const Options& options) {
    auto result = compare(options, plexus_throughput, floor_throughput);
    result.scenario = "throughput_" + std::to_string(options.hops) + "hop";
    result.latency_label = "write->read";
    result.title = "throughput, " + hops_text(options.hops) + ", " + std::to_string(options.size) +
                   " B: " + std::to_string(throughput_count(options)) + " messages per run, median of " +
                   std::to_string(options.repeat) + " runs";
    print(result, options.json);
    return 0;
}

int run_memory(const Options& options) {
    TempDir dir;
    const auto topology = Topology::plexus(dir, options.plexusd, 1);
    const pid_t daemon = topology->pids().front();
    RunDeadline deadline;
    MemoryResult result;
    result.ports = options.ports;
    result.idle_mb = static_cast<double>(rss_kib(daemon)) / 1024;
    Client client(Client::Options{topology->near_socket(), std::chrono::milliseconds(10000)});
    std::vector<Port> ports;
    ports.reserve(options.ports);
    for (std::size_t i = 0; i < options.ports; ++i)
        ports.push_back(client.open("/bench/memory/" + std::to_string(i)));
    result.ports_mb = static_cast<double>(rss_kib(daemon)) / 1024;
    print(result, options.json);
    return 0;
}

}  // namespace plexus::bench
