#include "bridges_scenario.hpp"

#include <pwd.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "hosts_network.hpp"
#include "measurement.hpp"
#include "topology.hpp"

namespace plexus::bench::bridges {

namespace {

using namespace std::chrono_literals;

constexpr int broker_port = 18830;  // inside the bench's own namespace: nothing else listens there

/// What one pinger run printed.
struct PingResult {
    double p50_us = 0;
    double p99_us = 0;
    double stream_msgs_per_s = 0;
    bool complete = false;
};

class Bench {
public:
    Bench(const BridgesOptions& options) : options_(options), network_(1, dir_.path()) {
        self_ = std::filesystem::read_symlink("/proc/self/exe").string();
        const std::string socket = dir_.file("bench.sock");
        const std::string ready = dir_.file("plexusd.ready");
        start_when_ready(
            daemon_,
            network_.wrap(0, {options.plexusd, "--embedded-names", "--names", "127.0.0.1:0", "--socket",
                              socket, "--node", "bench", "--ready-file", ready, "--log-level", "warn"}),
            ready, dir_.file("plexusd.log"), "plexusd");
        const auto names = nlohmann::json::parse(read_file(ready)).value("names", "");
        ::setenv("PLEXUS_SOCKET", socket.c_str(), 1);  // the bridges started below talk to it
        if (!names.empty())
            ::setenv("PLEXUS_NAMES", names.c_str(), 1);
        // Started as root, mosquitto becomes the user `mosquitto` unless told to stay who it is.
        const passwd* user = ::getpwuid(::geteuid());
        std::ofstream(dir_.file("mosquitto.conf")) << "listener " << broker_port << " 127.0.0.1\n"
                                                   << "allow_anonymous true\n"
                                                   << "set_tcp_nodelay true\n"
                                                   << "user " << (user ? user->pw_name : "root") << "\n";
    }

    /// One pinger run along `link`'s path, direct or through a bridge.
    PingResult run(const std::string& link, std::size_t size, bool bridged) {
        std::vector<std::unique_ptr<ChildProcess>> processes;
        const std::string tag = link + "-" + std::to_string(size) + (bridged ? "-bridged" : "-direct");
        const bool dds = link == "dds";
        if (!dds) {
            processes.push_back(std::make_unique<ChildProcess>(
                network_.wrap(0, {options_.mosquitto, "-c", dir_.file("mosquitto.conf")}),
                dir_.file(tag + "-broker.log")));
        }
        const std::string ping = dds ? "/bench/ping" : "bench/ping";
        const std::string pong = dds ? "/bench/pong" : "bench/pong";
        const std::string relayed = dds ? "/bench/relayed" : "bench/relayed";
        const std::string broker = "127.0.0.1:" + std::to_string(broker_port);
        if (bridged) {
            std::vector<std::string> argv{options_.bridge, "--log-level", "warn", dds ? "ros2" : "mqtt"};
            if (dds) {
                argv.insert(argv.end(), {"--in", ping + "=/bench/in:sensor_msgs/msg/Image", "--out",
                                         "/bench/back=" + relayed + ":sensor_msgs/msg/Image"});
            } else {
                argv.insert(argv.end(), {"--broker", broker, "--payload", "raw", "--in", ping + "=/bench/in",
                                         "--out", "/bench/back=" + relayed});
            }
            processes.push_back(
                std::make_unique<ChildProcess>(network_.wrap(0, argv), dir_.file(tag + "-bridge.log")));
            connect("/bench/in", "/bench/back", *processes.back());
        }
        std::vector<std::string> echo{
            self_,   "bridge-echo", "--link",   link,  "--in", bridged ? relayed : ping,
            "--out", pong,          "--broker", broker};
        processes.push_back(
            std::make_unique<ChildProcess>(network_.wrap(0, echo), dir_.file(tag + "-echo.log")));
        const bool large = size >= 65536;
        const std::size_t count = (large ? 200 : 2000) / (options_.quick ? 10 : 1);
        const std::size_t stream = (large ? 300 : 20000) / (options_.quick ? 10 : 1);
        const std::string out = dir_.file(tag + "-ping.out");
        std::vector<std::string> pinger{self_,      "bridge-ping",
                                        "--link",   link,
                                        "--out",    ping,
                                        "--in",     pong,
                                        "--broker", broker,
                                        "--size",   std::to_string(size),
                                        "--count",  std::to_string(count),
                                        "--stream", std::to_string(stream)};
        ChildProcess ping_process(network_.wrap(0, pinger), out);
        if (!poll_until([&] { return !ping_process.running(); }, 600s))
            throw std::runtime_error(tag + ": the pinger did not finish:\n" + ping_process.log_tail());
        const auto text = read_file(out);
        const auto brace = text.rfind('{');
        const auto figures = brace == std::string::npos
                                 ? nlohmann::json()
                                 : nlohmann::json::parse(text.substr(brace), nullptr, false);
        if (!figures.is_object())
            throw std::runtime_error(tag + ": the pinger printed no figures:\n" + text);
        PingResult result;
        result.p50_us = figures.value("p50_us", 0.0);
        result.p99_us = figures.value("p99_us", 0.0);
        result.stream_msgs_per_s = figures.value("stream_msgs_per_s", 0.0);
        result.complete = figures.value("lost", 1) == 0 && !figures.value("stream_stalled", true);
        return result;
    }

private:
    /// Connects two of the bridge's ports once it has opened them.
    void connect(const std::string& source, const std::string& destination, ChildProcess& bridge) {
        const bool made = poll_until(
            [&] {
                if (!bridge.running())
                    return true;
                return run_command(
                           network_.wrap(0, {options_.plexus, "connect", source, destination, "local"}))
                           .status == 0;
            },
            30s);
        if (!made || !bridge.running())
            throw std::runtime_error("the bridge never opened its ports:\n" + bridge.log_tail());
    }

    const BridgesOptions& options_;
    TempDir dir_;
    HostsNetwork network_;
    std::string self_;
    std::vector<std::unique_ptr<ChildProcess>> daemon_;
};

}  // namespace

int run_bridges(const BridgesOptions& options) {
    Bench bench(options);
    const int repeat = options.quick ? 1 : options.repeat;
    if (!options.json) {
        std::cout << "bridges: one-way p50/p99 (round trip / 2) and a stream's sustained rate (8 in flight), "
                     "direct against through plexus-bridge; medians of "
                  << repeat << " alternated runs\n";
        std::cout << std::left << std::setw(6) << "link" << std::setw(9) << "size" << std::setw(22)
                  << "direct p50/p99 us" << std::setw(22) << "bridged p50/p99 us" << std::setw(14)
                  << "added p50 us" << std::setw(16) << "direct msg/s" << std::setw(16) << "bridged msg/s"
                  << "complete\n";
    }
    for (const auto& link : options.links) {
        for (const auto size : options.sizes) {
            std::vector<double> direct_p50, direct_p99, bridged_p50, bridged_p99, direct_rate, bridged_rate;
            bool complete = true;
            for (int run = 0; run < repeat; ++run) {
                // Alternated, so that the machine's moods fall on both alike.
                const auto direct = bench.run(link, size, false);
                const auto bridged = bench.run(link, size, true);
                direct_p50.push_back(direct.p50_us);
                direct_p99.push_back(direct.p99_us);
                direct_rate.push_back(direct.stream_msgs_per_s);
                bridged_p50.push_back(bridged.p50_us);
                bridged_p99.push_back(bridged.p99_us);
                bridged_rate.push_back(bridged.stream_msgs_per_s);
                complete = complete && direct.complete && bridged.complete;
            }
            const double d50 = median(direct_p50), b50 = median(bridged_p50);
            if (options.json) {
                std::cout << nlohmann::json{{"link", link},
                                            {"size", size},
                                            {"direct_p50_us", d50},
                                            {"direct_p99_us", median(direct_p99)},
                                            {"bridged_p50_us", b50},
                                            {"bridged_p99_us", median(bridged_p99)},
                                            {"added_p50_us", b50 - d50},
                                            {"direct_msgs_per_s", median(direct_rate)},
                                            {"bridged_msgs_per_s", median(bridged_rate)},
                                            {"complete", complete}}
                                 .dump()
                          << std::endl;
                continue;
            }
            std::ostringstream direct_text, bridged_text;
            direct_text << std::fixed << std::setprecision(1) << d50 << " / " << median(direct_p99);
            bridged_text << std::fixed << std::setprecision(1) << b50 << " / " << median(bridged_p99);
            std::cout << std::left << std::setw(6) << link << std::setw(9) << size << std::setw(22)
                      << direct_text.str() << std::setw(22) << bridged_text.str() << std::setw(14)
                      << std::fixed << std::setprecision(1) << b50 - d50 << std::setw(16)
                      << std::setprecision(0) << median(direct_rate) << std::setw(16) << median(bridged_rate)
                      << (complete ? "yes" : "NO: messages lost or a stream stalled") << std::endl;
        }
    }
    return 0;
}

}  // namespace plexus::bench::bridges
