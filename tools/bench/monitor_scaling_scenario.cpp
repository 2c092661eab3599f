// plexus-bench monitor-scaling: do independent monitored connections use more than one core?
// One daemon, N = 1, 2, 4 connections, each with its own writer and reader and a recv-side monitor
// that spends ~20 us per message (a busy wait on the monitor clock). Total messages per second
// across the N connections, against one connection, in the same run (median of --repeat runs).
// Beside each figure, the CPU time the daemon and this process spent per message: with the same
// connections and an `accept` that returns at once, it is what a message costs outside the script,
// and it bounds what N connections can reach on the machine's cores (printed as the ceiling).
#include <algorithm>
#include <chrono>
#include <fstream>
#include <iostream>
#include <thread>

#include <unistd.h>

#include "measurement.hpp"
#include "plexus/client.hpp"
#include "process_stats.hpp"
#include "scenarios.hpp"
#include "topology.hpp"

namespace plexus::bench {

namespace {

constexpr const char* busy_script = R"(-- spends about 20 us of the monitor's thread on each message
PortMonitor.accept = function(msg)
    local start = PortMonitor.now()
    while PortMonitor.now() - start < 20e-6 do end
    return true
end
)";

constexpr const char* pass_script = "PortMonitor.accept = function(msg) return true end\n";

struct Run {
    double msgs_per_s = 0;
    double cpu_us_per_msg = 0;  ///< the daemon's and this process's CPU time, per message
};

/// Streams `count` messages through each of `connections` connections monitored by `script` at
/// once; returns the total messages per second from the first write to the last read.
Run run_once(const Topology& topology, const std::string& script, int connections, int count, int run) {
    const std::string& socket = topology.near_socket();
    Client::Options client_options;
    client_options.socket = socket;
    // A client (its own session with the daemon) per port, as independent components have: on one
    // shared session, a daemon holding back one writer (its connection's monitor is behind) holds
    // back every port of that session, and the connections are no longer independent.
    std::vector<std::unique_ptr<Client>> clients;
    std::vector<Port> outs;
    std::vector<Port> ins;
    for (int i = 0; i < connections; ++i) {
        const std::string suffix = std::to_string(run) + "-" + std::to_string(i);
        const std::string out = "/scaling/out" + script + suffix;
        const std::string in = "/scaling/in" + script + suffix;
        clients.push_back(std::make_unique<Client>(client_options));
        outs.push_back(clients.back()->open(out));
        clients.push_back(std::make_unique<Client>(client_options));
        ins.push_back(clients.back()->open(in));
        clients.back()->connect(out, in, "local+recv.portmonitor+type.lua+file." + script);
    }
    std::vector<pid_t> processes = topology.pids();
    processes.push_back(::getpid());
    const double cpu_before = cpu_seconds(processes);
    const auto start = std::chrono::steady_clock::now();
    std::vector<std::thread> threads;
    for (int i = 0; i < connections; ++i) {
        threads.emplace_back([&, i] {
            for (int n = 1; n <= count; ++n)
                outs[i].write(Value(n), n % 32 == 0 || n == count);
        });
        threads.emplace_back([&, i] {
            for (int got = 0; got < count;) {
                if (!ins[i].read(std::chrono::seconds(30)))
                    throw std::runtime_error("monitor-scaling: a reader waited 30 s for a message");
                ++got;
            }
        });
    }
    for (auto& thread : threads)
        thread.join();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double messages = static_cast<double>(connections) * count;
    return {messages / seconds, (cpu_seconds(processes) - cpu_before) * 1e6 / messages};
}

}  // namespace

int run_monitor_scaling(const Options& options) {
    TempDir dir;
    std::ofstream(dir.file("busy_20us.lua")) << busy_script;
    std::ofstream(dir.file("pass.lua")) << pass_script;
    const auto topology = Topology::plexus(dir, options.plexusd, 1, {"--scripts", dir.path()});
    const int count = 20000;
    const std::vector<int> sizes{1, 2, 4};
    std::vector<std::vector<double>> rates(sizes.size());
    std::vector<std::vector<double>> cpu(sizes.size());
    std::vector<double> outside_script;
    for (int run = 0; run < options.repeat; ++run) {
        for (std::size_t s = 0; s < sizes.size(); ++s) {
            const Run result = run_once(*topology, "busy_20us", sizes[s], count, run);
            rates[s].push_back(result.msgs_per_s);
            cpu[s].push_back(result.cpu_us_per_msg);
        }
        outside_script.push_back(run_once(*topology, "pass", 2, count, run).cpu_us_per_msg);
    }
    const double one = median(rates[0]);
    const double overhead = median(outside_script);
    const unsigned cores = std::thread::hardware_concurrency();
    // Each message needs 20 us of a worker plus `overhead` of CPU elsewhere; `cores` cores can at
    // best give every message both, and one connection can never go faster than its one worker.
    const double ceiling = std::min(cores * 1e6 / (20 + overhead), 2 * 1e6 / 20);
    std::cout << "monitor-scaling: " << count << " messages per connection, a ~20 us accept on each, "
              << cores << " cores, median of " << options.repeat << " runs\n";
    for (std::size_t s = 0; s < sizes.size(); ++s) {
        const double rate = median(rates[s]);
        if (options.json)
            std::cout << R"({"scenario":"monitor_scaling","connections":)" << sizes[s] << R"(,"msgs_per_s":)"
                      << rate << R"(,"against_one":)" << rate / one << R"(,"cpu_us_per_msg":)"
                      << median(cpu[s]) << "}\n";
        else
            std::cout << "  " << sizes[s] << " connection(s): " << static_cast<long>(rate)
                      << " msgs/s in total, " << rate / one << "x one connection, " << median(cpu[s])
                      << " us CPU per message\n";
    }
    if (options.json)
        std::cout << R"({"scenario":"monitor_scaling_outside_script","cpu_us_per_msg":)" << overhead
                  << R"(,"ceiling_msgs_per_s":)" << ceiling << "}\n";
    else
        std::cout << "  outside the script (2 connections, accept returns at once): " << overhead
                  << " us CPU per message (daemon + clients); ceiling on " << cores
                  << " cores: " << static_cast<long>(ceiling) << " msgs/s\n";
    return 0;
}

}  // namespace plexus::bench
