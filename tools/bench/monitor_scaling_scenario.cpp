// plexus-bench monitor-scaling: do independent monitored connections use more than one core?
// One daemon, N = 1, 2, 4 connections, each with its own writer and reader and a recv-side monitor
// that spends ~20 us per message (a busy wait on the monitor clock). Total messages per second
// across the N connections, against one connection, in the same run (median of --repeat runs).
#include <algorithm>
#include <chrono>
#include <fstream>
#include <iostream>
#include <thread>

#include "plexus/client.hpp"
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

/// Streams `count` messages through each of `connections` monitored connections at once; returns
/// the total messages per second from the first write to the last read.
double run_once(const std::string& socket, int connections, int count, int run) {
    Client::Options client_options;
    client_options.socket = socket;
    Client client(client_options);
    std::vector<Port> outs;
    std::vector<Port> ins;
    for (int i = 0; i < connections; ++i) {
        const std::string suffix = std::to_string(run) + "-" + std::to_string(i);
        outs.push_back(client.open("/scaling/out" + suffix));
        ins.push_back(client.open("/scaling/in" + suffix));
        client.connect("/scaling/out" + suffix, "/scaling/in" + suffix,
                       "local+recv.portmonitor+type.lua+file.busy_20us");
    }
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
    return connections * count / seconds;
}

}  // namespace

int run_monitor_scaling(const Options& options) {
    TempDir dir;
    std::ofstream(dir.file("busy_20us.lua")) << busy_script;
    const auto topology = Topology::plexus(dir, options.plexusd, 1, {"--scripts", dir.path()});
    const int count = 20000;
    const std::vector<int> sizes{1, 2, 4};
    std::vector<std::vector<double>> rates(sizes.size());
    for (int run = 0; run < options.repeat; ++run) {
        for (std::size_t s = 0; s < sizes.size(); ++s)
            rates[s].push_back(run_once(topology->near_socket(), sizes[s], count, run));
    }
    auto median = [](std::vector<double> values) {
        std::sort(values.begin(), values.end());
        return values[values.size() / 2];
    };
    const double one = median(rates[0]);
    std::cout << "monitor-scaling: " << count << " messages per connection, a ~20 us accept on each, "
              << std::thread::hardware_concurrency() << " cores, median of " << options.repeat << " runs\n";
    for (std::size_t s = 0; s < sizes.size(); ++s) {
        const double rate = median(rates[s]);
        if (options.json)
            std::cout << R"({"scenario":"monitor_scaling","connections":)" << sizes[s] << R"(,"msgs_per_s":)"
                      << rate << R"(,"against_one":)" << rate / one << "}\n";
        else
            std::cout << "  " << sizes[s] << " connection(s): " << static_cast<long>(rate)
                      << " msgs/s in total, " << rate / one << "x one connection\n";
    }
    return 0;
}

}  // namespace plexus::bench
