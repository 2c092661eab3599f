// plexus-bench arbitration: what arbitration in the input port costs, and how fast it switches.
//
// Throughput rows: one measured stream into a sink, plus N-1 competing connections into the same
// sink, one daemon. `none` is the stream alone on a plain local connection.
//   constraints_N: the stream's constraint is "not e_busy_1 and ... not e_busy_{N-1}", competitor
//                  k's is "e_busy_k" (consistent: at most one can deliver); no events are set, so
//                  the stream passes and each message costs N-1 look-ups in the event container.
//   priority_N:    every connection has a recv.priority clause; the competitors have sent once
//                  (a long tc keeps them active, bias 0 keeps them from winning) and the stream
//                  excites each of them, so every message solves a full N x N system.
// switch_ms: a second stream at 1 kHz and a switcher (competitor 1) that takes over for 20
// messages and stops. The switch measured is the way back: from the moment the switcher's hold
// ends (its event's lifetime, or its stimulation's tc, after its last message) to the first
// delivered message of the stream. One message period is 1 ms.
#include <algorithm>
#include <atomic>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "plexus_measurements.hpp"
#include "report.hpp"
#include "run_deadline.hpp"
#include "scenarios.hpp"
#include "topology.hpp"

namespace plexus::bench {

namespace {

using namespace std::chrono_literals;
using SteadyClock = std::chrono::steady_clock;

/// Raises `event` (with `lifetime` seconds) on every message: the switcher of the constraints rows.
constexpr const char* raise_script = R"(-- sets an event on every message
local event, lifetime
PortMonitor.create = function(options)
    event = options.event
    lifetime = tonumber(options.lifetime)
    return true
end
PortMonitor.accept = function(msg)
    PortMonitor.setEvent(event, lifetime)
    return true
end
)";

constexpr double switch_hold_s = 0.05;  ///< the switcher's event lifetime, or its tc
constexpr auto stream_period = 1ms;
constexpr int switcher_messages = 20;

enum class Kind { constraints, priority };

struct Competitor {
    std::string port;
    std::string carrier;
};

/// The carriers of a port with `n` connections: the measured stream from `stream`, competitors
/// from `prefix`1 .. `prefix`(n-1). Competitor 1 is the switcher: when it streams, it wins.
struct Layout {
    std::string stream_carrier;
    std::vector<Competitor> competitors;
};

Layout layout(Kind kind, int n, const std::string& stream, const std::string& prefix) {
    Layout result;
    if (kind == Kind::constraints) {
        std::string constraint;
        for (int k = 1; k < n; ++k) {
            const std::string event = "e_busy_" + std::to_string(k);
            constraint += (k == 1 ? "not " : " and not ") + event;
            std::string carrier = "local+recv.portmonitor+constraint." + event;
            if (k == 1) {
                carrier = "local+recv.portmonitor+type.lua+file.raise+event." + event + "+lifetime." +
                          std::to_string(switch_hold_s) + "+constraint." + event;
            }
            result.competitors.push_back({prefix + std::to_string(k), carrier});
        }
        result.stream_carrier = "local+recv.portmonitor+constraint." + constraint;
        return result;
    }
    const std::string tc = std::to_string(switch_hold_s);
    std::string excites;
    for (int k = 1; k < n; ++k) {
        const std::string port = prefix + std::to_string(k);
        excites += (k == 1 ? "" : ",") + port + ":0.1";
        // The switcher inhibits the stream and wins while it is active; the others never win.
        const std::string carrier = k == 1 ? "local+recv.priority+tc." + tc + "+ex." + stream + ":-1"
                                           : "local+recv.priority+tc.1000+bs.0";
        result.competitors.push_back({port, carrier});
    }
    result.stream_carrier = "local+recv.priority+tc.1000" + (excites.empty() ? "" : "+ex." + excites);
    return result;
}

/// Opens and connects the competitors; the always-active ones (priority rows, k >= 2) send once.
std::vector<Port> open_competitors(Client& client, const Layout& layout, Kind kind, const std::string& sink) {
    std::vector<Port> ports;
    for (const auto& competitor : layout.competitors) {
        ports.push_back(client.open(competitor.port));
        connect_when_registered(client, competitor.port, sink, competitor.carrier);
    }
    if (kind == Kind::priority) {
        for (std::size_t k = 1; k < ports.size(); ++k)
            ports[k].write(Value{{"stimulate", true}});
    }
    return ports;
}

/// Medians of the switch time, in ms, over `repeat` switches on a stream at 1 kHz.
double measure_switch(const Topology& topology, Kind kind, int n, int repeat, const std::string& name) {
    Client writer = connect_client(topology.near_socket());
    Client reader = connect_client(topology.far_socket());
    const std::string stream_port = "/bench/" + name + "-stream";
    auto sink = reader.open("/bench/" + name + "-sink", {QueuePolicy::latest, 100000});
    auto stream = writer.open(stream_port);
    const Layout ports = layout(kind, n, stream_port, "/bench/" + name + "-c");
    connect_when_registered(writer, stream_port, sink.name(), ports.stream_carrier);
    auto competitors = open_competitors(writer, ports, kind, sink.name());
    Port& switcher = competitors.front();

    // Arrival times of the stream's delivered messages, and whether the switcher got through.
    std::mutex mutex;
    std::vector<SteadyClock::time_point> stream_arrivals;
    std::size_t switcher_delivered = 0;
    std::atomic<bool> running{true};
    std::jthread reading([&] {
        while (running) {
            auto message = sink.read(50ms);
            if (!message)
                continue;
            std::lock_guard lock(mutex);
            if (message->envelope.source == stream_port)
                stream_arrivals.push_back(SteadyClock::now());
            else if (message->envelope.source == switcher.name())
                ++switcher_delivered;
        }
    });
    std::jthread streaming([&] {
        auto next = SteadyClock::now();
        while (running) {
            stream.write(Value{{"c", 0.9}});
            next += stream_period;
            std::this_thread::sleep_until(next);
        }
    });
    std::this_thread::sleep_for(200ms);  // warm-up: the stream flows and wins

    std::vector<double> switches;
    for (int r = 0; r < repeat; ++r) {
        auto next = SteadyClock::now();
        SteadyClock::time_point last_sent;
        for (int i = 0; i < switcher_messages; ++i) {
            switcher.write(Value{{"switch", i}});
            last_sent = SteadyClock::now();
            next += stream_period;
            std::this_thread::sleep_until(next);
        }
        const auto hold_ends = last_sent + std::chrono::duration_cast<SteadyClock::duration>(
                                               std::chrono::duration<double>(switch_hold_s));
        std::this_thread::sleep_until(hold_ends + 100ms);  // the stream is back by then
        std::lock_guard lock(mutex);
        auto back = std::find_if(stream_arrivals.begin(), stream_arrivals.end(),
                                 [&](SteadyClock::time_point t) { return t > last_sent; });
        if (back == stream_arrivals.end())
            throw std::runtime_error(
                "arbitration switch: the stream never came back after the switcher stopped");
        switches.push_back(std::chrono::duration<double, std::milli>(*back - hold_ends).count());
    }
    running = false;
    streaming.join();
    reading.join();
    if (switcher_delivered == 0)
        throw std::runtime_error("arbitration switch: the switcher never won");
    std::sort(switches.begin(), switches.end());
    return switches[switches.size() / 2];
}

}  // namespace

int run_arbitration(const Options& options) {
    TempDir dir;
    std::ofstream(dir.file("raise.lua")) << raise_script;
    const auto topology = Topology::plexus(dir, options.plexusd, 1, {"--scripts", dir.path()});

    struct Variant {
        std::string system;
        Kind kind = Kind::constraints;
        int connections = 1;
    };
    std::vector<Variant> variants{{"none", Kind::constraints, 1}};
    for (const Kind kind : {Kind::constraints, Kind::priority}) {
        for (const int n : {2, 4, 8})
            variants.push_back(
                {(kind == Kind::constraints ? "constraints_" : "priority_") + std::to_string(n), kind, n});
    }
    std::vector<std::unique_ptr<Measurement>> measurements;
    std::vector<double> switch_ms{-1};
    for (const auto& variant : variants) {
        StreamSpec spec{variant.system + "-", detection(options.size), "local", check_detection, {}};
        if (variant.connections > 1) {
            const Kind kind = variant.kind;
            const std::string stream = "/bench/" + variant.system + "-source";
            const Layout ports = layout(kind, variant.connections, stream, "/bench/" + variant.system + "-c");
            spec.carrier = ports.stream_carrier;
            spec.prepare = [ports, kind](Client& client, const std::string& sink) {
                return open_competitors(client, ports, kind, sink);
            };
            RunDeadline deadline;
            switch_ms.push_back(measure_switch(*topology, kind, variant.connections, options.repeat,
                                               "switch-" + variant.system));
        }
        measurements.push_back(plexus_stream(*topology, options, std::move(spec)));
    }
    std::vector<std::vector<RunResult>> runs(variants.size());
    for (int run = 0; run < options.repeat; ++run) {
        for (std::size_t i = 0; i < variants.size(); ++i) {
            RunDeadline deadline;
            runs[i].push_back(measurements[i]->run());
        }
    }
    VariantsResult result;
    result.scenario = "arbitration_1hop";
    result.size = options.size;
    result.title = "arbitration, 1 hop, " + std::to_string(options.size) +
                   " B maps, N connections into one port: " + std::to_string(throughput_count(options)) +
                   " messages per run, median of " + std::to_string(options.repeat) +
                   " runs; switch_ms: median of " + std::to_string(options.repeat) + " switches at 1 kHz";
    for (std::size_t i = 0; i < variants.size(); ++i)
        result.systems.emplace_back(variants[i].system, median_of(runs[i]));
    result.switch_ms = switch_ms;
    print(result, options.json);
    return 0;
}

}  // namespace plexus::bench
