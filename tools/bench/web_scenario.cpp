// plexus-bench web: what plexusd's web endpoint (docs/WEB.md) costs (issue 27).
//
// 1. The data path. The one-hop latency and throughput of `plexus-bench latency` / `throughput`
//    on two daemons: (a) without --http, (b) with --http 127.0.0.1:0, and during each of its runs
//    --idle TCP connections to the endpoint that never send a request plus one client reading
//    /api/stream as fast as it can. Runs alternate (a b, b a, ...); medians and (b)/(a). The
//    measurement's own ports have connections in, so the stream carries arbitration at 20 Hz.
// 2. The stream's cost. One plexusd with --http running the fetch robot (docs/FETCH.md, brought up
//    with `plexus up`): its CPU per second over a window without a stream client and over one with a
//    stream client reading, alternated; medians and the difference in CPU ms per second.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "hosts_network.hpp"
#include "plexus_measurements.hpp"
#include "process_stats.hpp"
#include "report.hpp"
#include "run_deadline.hpp"
#include "scenarios.hpp"
#include "topology.hpp"

namespace plexus::bench {

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// The endpoint closes a connection that sent no request for http_read_timeout_ms (10 s by
// default); the idle connections must outlive every run.
constexpr const char* web_config = R"({"http_read_timeout_ms": 600000})";

/// The web endpoint's HOST:PORT, from the daemon's ready file.
std::string http_address(const Topology& topology) {
    const auto ready = nlohmann::json::parse(topology.ready(0));
    const std::string address = ready.value("http", "");
    if (address.empty())
        throw std::runtime_error("plexusd's ready file has no \"http\" address: " + topology.ready(0));
    return address;
}

/// A TCP connection to an IPv4 HOST:PORT.
int connect_tcp(const std::string& address) {
    const auto colon = address.rfind(':');
    sockaddr_in peer{};
    peer.sin_family = AF_INET;
    if (colon == std::string::npos ||
        ::inet_pton(AF_INET, address.substr(0, colon).c_str(), &peer.sin_addr) != 1)
        throw std::runtime_error("not an IPv4 HOST:PORT: " + address);
    peer.sin_port = htons(static_cast<std::uint16_t>(std::stoi(address.substr(colon + 1))));
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0)
        throw std::runtime_error("socket failed");
    if (::connect(fd, reinterpret_cast<const sockaddr*>(&peer), sizeof peer) != 0) {
        const int error = errno;
        ::close(fd);
        throw std::runtime_error("cannot connect to " + address + ": " + std::strerror(error));
    }
    return fd;
}

/// True while the peer has not closed the connection (nothing is read from it).
bool still_open(int fd) {
    char byte = 0;
    const ssize_t n = ::recv(fd, &byte, 1, MSG_PEEK | MSG_DONTWAIT);
    return n > 0 || (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK));
}

/// A client of /api/stream: one thread with one socket, reading as fast as it can and throwing the
/// bytes away, counting them and the `arbitration` events among them.
class StreamReader {
public:
    explicit StreamReader(const std::string& address) : fd_(connect_tcp(address)) {
        const std::string request = "GET /api/stream HTTP/1.1\r\nHost: " + address + "\r\n\r\n";
        if (::send(fd_, request.data(), request.size(), MSG_NOSIGNAL) !=
            static_cast<ssize_t>(request.size())) {
            ::close(fd_);
            throw std::runtime_error("cannot send the /api/stream request");
        }
        thread_ = std::thread([this] { read_all(); });
    }
    ~StreamReader() {
        ::shutdown(fd_, SHUT_RDWR);  // wakes the blocked recv
        thread_.join();
        ::close(fd_);
    }
    StreamReader(const StreamReader&) = delete;
    StreamReader& operator=(const StreamReader&) = delete;

    /// Waits until an arbitration event has arrived: the stream is flowing at its 20 Hz.
    void wait_for_arbitration() {
        if (!poll_until([&] { return arbitration_events() > 0 || closed_; }, 10s) ||
            arbitration_events() == 0)
            throw std::runtime_error("no arbitration event on /api/stream within 10 s" + error_text());
    }
    std::uint64_t bytes() const { return bytes_; }
    std::uint64_t arbitration_events() const { return arbitration_events_; }
    /// Throws if the endpoint closed the stream (or refused it).
    void check_open() const {
        if (closed_)
            throw std::runtime_error("the endpoint closed /api/stream" + error_text());
    }

private:
    std::string error_text() const {
        std::lock_guard lock(mutex_);
        return error_.empty() ? "" : ": " + error_;
    }

    void read_all() {
        static constexpr std::string_view marker = "event: arbitration\n";
        std::vector<char> buffer(64 * 1024);
        std::string head;   // the response's status line and headers
        std::string carry;  // the end of the last read, for a marker split over two reads
        for (;;) {
            const ssize_t n = ::recv(fd_, buffer.data(), buffer.size(), 0);
            if (n < 0 && errno == EINTR)
                continue;
            if (n <= 0)
                break;
            bytes_ += static_cast<std::uint64_t>(n);
            std::string_view chunk(buffer.data(), static_cast<std::size_t>(n));
            if (head.find("\r\n\r\n") == std::string::npos) {
                head.append(chunk);
                if (head.rfind("HTTP/1.1 200", 0) != 0 && head.size() >= 12) {
                    std::lock_guard lock(mutex_);
                    error_ = head.substr(0, head.find("\r\n"));
                    break;
                }
            }
            std::string text = carry;
            text.append(chunk);
            for (auto at = text.find(marker); at != std::string::npos; at = text.find(marker, at + 1))
                ++arbitration_events_;
            carry = text.substr(text.size() - std::min(text.size(), marker.size() - 1));
        }
        closed_ = true;
    }

    int fd_;
    std::atomic<std::uint64_t> bytes_{0};
    std::atomic<std::uint64_t> arbitration_events_{0};
    std::atomic<bool> closed_{false};
    mutable std::mutex mutex_;
    std::string error_;
    std::thread thread_;
};

/// What (b) adds during one of its runs: idle connections that never send a request, and a stream
/// reader. Checks at the end that the endpoint kept all of them.
class WebLoad {
public:
    WebLoad(const std::string& address, int idle) {
        for (int i = 0; i < idle; ++i)
            idle_.push_back(connect_tcp(address));
        stream_ = std::make_unique<StreamReader>(address);
        stream_->wait_for_arbitration();
        start_ = Clock::now();
        start_bytes_ = stream_->bytes();
        start_events_ = stream_->arbitration_events();
    }
    ~WebLoad() {
        for (const int fd : idle_)
            ::close(fd);
    }
    WebLoad(const WebLoad&) = delete;
    WebLoad& operator=(const WebLoad&) = delete;

    /// Throws unless every connection is still open; returns {arbitration events/s, stream kB/s}.
    std::pair<double, double> finish() const {
        stream_->check_open();
        for (const int fd : idle_) {
            if (!still_open(fd))
                throw std::runtime_error("the web endpoint closed an idle connection during the run");
        }
        const double seconds = std::chrono::duration<double>(Clock::now() - start_).count();
        return {static_cast<double>(stream_->arbitration_events() - start_events_) / seconds,
                static_cast<double>(stream_->bytes() - start_bytes_) / 1e3 / seconds};
    }

private:
    std::vector<int> idle_;
    std::unique_ptr<StreamReader> stream_;
    Clock::time_point start_;
    std::uint64_t start_bytes_ = 0;
    std::uint64_t start_events_ = 0;
};

struct DataPathResult {
    ScenarioResult latency;
    ScenarioResult throughput;
    double arbitration_per_s = 0;  ///< median, during (b)'s runs
    double stream_kb_per_s = 0;
};

DataPathResult measure_data_path(const Options& options) {
    TempDir plain_dir;
    TempDir web_dir;
    const std::string config = web_dir.file("web.json");
    std::ofstream(config) << web_config << '\n';
    const auto plain = Topology::plexus(plain_dir, options.plexusd, 1);
    const auto web =
        Topology::plexus(web_dir, options.plexusd, 1, {"--http", "127.0.0.1:0", "--config", config});
    const std::string address = http_address(*web);

    std::vector<RunResult> latency_a, latency_b, throughput_a, throughput_b;
    std::vector<double> events, kilobytes;
    {
        RunDeadline deadline;
        Options stream_options = options;
        stream_options.count = options.stream_count;
        const auto plain_latency = plexus_latency(*plain, options);
        const auto plain_throughput = plexus_throughput(*plain, stream_options);
        const auto web_latency = plexus_latency(*web, options);
        const auto web_throughput = plexus_throughput(*web, stream_options);
        auto measure_plain = [&] {
            latency_a.push_back(plain_latency->run());
            throughput_a.push_back(plain_throughput->run());
        };
        auto measure_web = [&] {
            WebLoad load(address, options.idle_connections);
            latency_b.push_back(web_latency->run());
            throughput_b.push_back(web_throughput->run());
            const auto [events_per_s, kb_per_s] = load.finish();
            events.push_back(events_per_s);
            kilobytes.push_back(kb_per_s);
        };
        for (int run = 0; run < options.repeat; ++run) {
            RunDeadline per_run;
            // Which goes first alternates too (a b, b a, ...): whatever the order does hits both alike.
            if (run % 2 == 0) {
                measure_plain();
                measure_web();
            } else {
                measure_web();
                measure_plain();
            }
        }
    }
    const std::string runs = ", median of " + std::to_string(options.repeat) + " runs each, alternated";
    const std::string load = "(web: --http with " + std::to_string(options.idle_connections) +
                             " idle connections and one /api/stream reader; no_http: without --http)";
    DataPathResult result;
    result.latency.scenario = "web_latency_1hop";
    result.latency.latency_label = "RTT/2";
    result.latency.title = "latency, 1 hop, " + std::to_string(options.size) +
                           " B: " + std::to_string(latency_count(options)) + " round trips per run" + runs +
                           "\n" + load;
    result.throughput.scenario = "web_throughput_1hop";
    result.throughput.latency_label = "write->read";
    Options stream_options = options;
    stream_options.count = options.stream_count;
    result.throughput.title = "throughput, 1 hop, " + std::to_string(options.size) +
                              " B: " + std::to_string(throughput_count(stream_options)) +
                              " messages per run" + runs;
    for (auto* scenario : {&result.latency, &result.throughput}) {
        scenario->size = options.size;
        scenario->plexus_label = "web";
        scenario->floor_label = "no_http";
    }
    result.latency.plexus = median_of(latency_b);
    result.latency.floor = median_of(latency_a);
    result.throughput.plexus = median_of(throughput_b);
    result.throughput.floor = median_of(throughput_a);
    for (const pid_t pid : web->pids())
        result.latency.plexusd_peak_rss_mb.push_back(static_cast<double>(peak_rss_kib(pid)) / 1024);
    for (const pid_t pid : plain->pids())
        result.latency.plexusd_peak_rss_mb.push_back(static_cast<double>(peak_rss_kib(pid)) / 1024);
    result.throughput.plexusd_peak_rss_mb = result.latency.plexusd_peak_rss_mb;
    result.arbitration_per_s = median(events);
    result.stream_kb_per_s = median(kilobytes);
    return result;
}

/// The application of options.app_file brought up with `plexus up` on a daemon; `plexus down` when
/// it goes (before the daemon: declare it after the topology).
class RunningApp {
public:
    RunningApp(const Options& options, const Topology& topology) {
        if (!std::filesystem::exists(options.plexus_cli))
            throw std::runtime_error(
                options.plexus_cli +
                " is missing: build the targets plexus and plexus-sim-* (or pass --plexus)");
        const auto ready = nlohmann::json::parse(topology.ready(0));
        prefix_ = {options.plexus_cli, "--socket", topology.near_socket(), "--names",
                   ready.at("names").get<std::string>()};
        app_ = options.app_file;
        auto up = prefix_;
        up.insert(up.end(), {"up", app_});
        const auto result = run_command(up);
        if (result.status != 0) {
            down();
            throw std::runtime_error("plexus up " + app_ + " failed (" + std::to_string(result.status) +
                                     "):\n" + result.output);
        }
    }
    ~RunningApp() { down(); }
    RunningApp(const RunningApp&) = delete;
    RunningApp& operator=(const RunningApp&) = delete;

private:
    void down() const {
        auto down = prefix_;
        down.insert(down.end(), {"down", app_});
        const auto result = run_command(down);
        if (result.status != 0)
            std::cerr << "plexus-bench: plexus down " << app_ << " failed:\n" << result.output;
    }

    std::vector<std::string> prefix_;
    std::string app_;
};

struct StreamCostResult {
    double without_ms_per_s = 0;  ///< medians of plexusd's CPU ms per wall second
    double with_ms_per_s = 0;
    double arbitration_per_s = 0;
    double stream_kb_per_s = 0;
    std::vector<double> without_runs, with_runs;
};

/// plexusd's CPU time in ms per second of wall time over one window.
double cpu_ms_per_s(pid_t daemon, double window_s) {
    const double before = cpu_seconds({daemon});
    const auto start = Clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double>(window_s));  // the measurement window
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return (cpu_seconds({daemon}) - before) * 1e3 / seconds;
}

StreamCostResult measure_stream_cost(const Options& options) {
    TempDir dir;
    const std::string scripts = (std::filesystem::path(options.app_file).parent_path() / ".." / "monitors")
                                    .lexically_normal()
                                    .string();
    const auto topology =
        Topology::plexus(dir, options.plexusd, 1, {"--scripts", scripts, "--http", "127.0.0.1:0"});
    const RunningApp robot(options, *topology);
    const std::string address = http_address(*topology);
    const pid_t daemon = topology->pids().front();
    // The robot's first seconds (components connecting, the world's first object) are not its
    // steady state; and no window starts right after the stream ended.
    constexpr auto settle = 2s;
    std::this_thread::sleep_for(settle);

    StreamCostResult result;
    std::vector<double> events, kilobytes;
    for (int run = 0; run < options.cost_repeat; ++run) {
        RunDeadline per_run;
        result.without_runs.push_back(cpu_ms_per_s(daemon, options.window_s));
        {
            StreamReader stream(address);
            stream.wait_for_arbitration();
            const auto bytes = stream.bytes();
            const auto arbitration = stream.arbitration_events();
            const auto start = Clock::now();
            result.with_runs.push_back(cpu_ms_per_s(daemon, options.window_s));
            stream.check_open();
            const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
            events.push_back(static_cast<double>(stream.arbitration_events() - arbitration) / seconds);
            kilobytes.push_back(static_cast<double>(stream.bytes() - bytes) / 1e3 / seconds);
        }
        std::this_thread::sleep_for(settle);
    }
    result.without_ms_per_s = median(result.without_runs);
    result.with_ms_per_s = median(result.with_runs);
    result.arbitration_per_s = median(events);
    result.stream_kb_per_s = median(kilobytes);
    return result;
}

std::string runs_text(const std::vector<double>& runs) {
    std::string text;
    for (const double run : runs) {
        char number[32];
        std::snprintf(number, sizeof number, "%s%.2f", text.empty() ? "" : " ", run);
        text += number;
    }
    return text;
}

}  // namespace

int run_web(const Options& given) {
    Options options = given;
    options.hops = 1;
    if (options.repeat > 0) {
        const auto data_path = measure_data_path(options);
        const double latency_ratio = data_path.latency.plexus.p50_us / data_path.latency.floor.p50_us;
        const double throughput_ratio =
            data_path.throughput.plexus.msgs_per_s / data_path.throughput.floor.msgs_per_s;
        const bool met = std::abs(latency_ratio - 1) <= 0.05 && std::abs(throughput_ratio - 1) <= 0.05;
        print(data_path.latency, options.json);
        print(data_path.throughput, options.json);
        if (options.json) {
            std::cout << nlohmann::ordered_json{{"scenario", "web_data_path_target"},
                                                {"latency_p50_ratio", latency_ratio},
                                                {"throughput_ratio", throughput_ratio},
                                                {"within_5_percent", met},
                                                {"stream_arbitration_per_s", data_path.arbitration_per_s},
                                                {"stream_kb_per_s", data_path.stream_kb_per_s}}
                             .dump()
                      << '\n';
        } else {
            std::printf("the stream during web's runs: %.1f arbitration events/s, %.1f kB/s read\n",
                        data_path.arbitration_per_s, data_path.stream_kb_per_s);
            std::printf("target (p50 latency and messages/s within 5%%): web/no_http %.3f and %.3f: %s\n\n",
                        latency_ratio, throughput_ratio, met ? "met" : "NOT met");
        }
        std::fflush(stdout);
    }
    if (options.cost_repeat > 0) {
        const auto cost = measure_stream_cost(options);
        if (options.json) {
            std::cout << nlohmann::ordered_json{{"scenario", "web_stream_cost"},
                                                {"app", options.app_file},
                                                {"window_s", options.window_s},
                                                {"cpu_ms_per_s_without", cost.without_ms_per_s},
                                                {"cpu_ms_per_s_with", cost.with_ms_per_s},
                                                {"added_cpu_ms_per_s",
                                                 cost.with_ms_per_s - cost.without_ms_per_s},
                                                {"stream_arbitration_per_s", cost.arbitration_per_s},
                                                {"stream_kb_per_s", cost.stream_kb_per_s}}
                             .dump()
                      << '\n';
        } else {
            std::printf(
                "the live stream's cost: plexusd CPU (ms per s) running %s, %g s windows, median of %d "
                "each, alternated\n",
                std::filesystem::path(options.app_file).filename().c_str(), options.window_s,
                options.cost_repeat);
            std::printf("  %-28s %10.2f   (runs: %s)\n", "no stream client", cost.without_ms_per_s,
                        runs_text(cost.without_runs).c_str());
            std::printf("  %-28s %10.2f   (runs: %s)\n", "one stream client reading", cost.with_ms_per_s,
                        runs_text(cost.with_runs).c_str());
            std::printf("  %-28s %10.2f   (%.1f arbitration events/s, %.1f kB/s on the stream)\n",
                        "added by the stream", cost.with_ms_per_s - cost.without_ms_per_s,
                        cost.arbitration_per_s, cost.stream_kb_per_s);
        }
    }
    return 0;
}

}  // namespace plexus::bench
