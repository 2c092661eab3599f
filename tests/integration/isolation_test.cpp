// A hostile monitor delays only its own connection (issue 19, DESIGN "Monitors, second pass"):
// with a script from tests/monitors/hostile/ running on every message of one connection, a second
// connection of the same daemon keeps delivering with p99 latency under 5 ms, `plexus list`
// answers within 1 s, the hostile calls are stopped and counted, and SIGTERM stops the daemon
// within 2 s. And order: 100,000 messages through a monitored connection arrive in order, none
// lost, while other monitored connections run beside it.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "../common/slowdown.hpp"
#include "harness.hpp"
#include "netns.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace isolation_test {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

/// A daemon that never quarantines, so the hostile script keeps running on every message.
std::vector<std::string> hostile_daemon_flags(const TempDir& dir) {
    const std::string config = dir.file("never-quarantine.json");
    std::ofstream(config) << R"({"monitor_quarantine_after": 1000000})";
    return {"--scripts", PLEXUS_HOSTILE_DIR, "--scripts", monitors_dir(), "--config", config};
}

/// Writes 1, 2, 3... every `pace` on a thread of its own until stopped (also when a test fails).
class PacedWriter {
public:
    PacedWriter(Port& port, std::chrono::microseconds pace, std::uint64_t count = 0)
        : thread_([this, &port, pace, count] {
              auto next = Clock::now();
              while (!stop_ && (count == 0 || written_ < count)) {
                  port.write(Value(static_cast<std::int64_t>(written_ + 1)));
                  ++written_;
                  next += pace;
                  std::this_thread::sleep_until(next);
              }
          }) {}
    ~PacedWriter() { stop(); }
    void stop() {
        stop_ = true;
        if (thread_.joinable())
            thread_.join();
    }

private:
    std::atomic<std::uint64_t> written_{0};
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

double ms(Clock::duration d) {
    return std::chrono::duration<double, std::milli>(d).count();
}

/// Reads `count` messages of 1, 2, 3... from `in`; returns their latencies (ms, sorted), fewer if
/// they stopped coming.
std::vector<double> calm_latencies(Port& in, std::uint64_t count) {
    std::vector<double> latencies;
    const auto deadline = Clock::now() + slower(30s);
    while (latencies.size() < count && Clock::now() < deadline) {
        auto message = in.read(200ms);
        if (!message)
            continue;
        const auto now_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                                std::chrono::system_clock::now().time_since_epoch())
                                .count();
        latencies.push_back(
            static_cast<double>(now_ns - static_cast<std::int64_t>(message->envelope.time_ns)) / 1e6);
        EXPECT_EQ(message->envelope.seq, latencies.size()) << "out of order or lost";
    }
    std::sort(latencies.begin(), latencies.end());
    return latencies;
}

/// A connection /NAME/out -> /NAME/in (a latest queue of 16) whose recv monitor is `script`, and a
/// calm one /calm/out -> /calm/in beside it, on one client of `daemon`.
struct MonitoredBesideCalm {
    MonitoredBesideCalm(const Daemon& daemon, const std::string& name, const std::string& script)
        : client(options_for(daemon)),
          monitored_out(client.open("/" + name + "/out")),
          monitored_in(client.open("/" + name + "/in", {QueuePolicy::latest, 16})),
          calm_out(client.open("/calm/out")),
          calm_in(client.open("/calm/in")) {
        client.connect("/" + name + "/out", "/" + name + "/in",
                       "local+recv.portmonitor+type.lua+file." + script);
        client.connect("/calm/out", "/calm/in", "local");
    }
    static Client::Options options_for(const Daemon& daemon) {
        Client::Options options;
        options.socket = daemon.socket();
        return options;
    }

    Client client;
    Port monitored_out;
    Port monitored_in;
    Port calm_out;
    Port calm_in;
};

struct CalmFigures {
    std::size_t delivered = 0;
    double p50 = 0;
    double p99 = 0;
};

/// A 500 Hz stream of 1,000 messages on the calm connection: how many arrived, and their latency.
CalmFigures measure_calm(Port& out, Port& in) {
    constexpr std::uint64_t count = 1000;
    PacedWriter calm(out, 2ms, count);
    const auto latencies = calm_latencies(in, count);
    CalmFigures figures;
    figures.delivered = latencies.size();
    if (latencies.size() == count) {
        figures.p50 = latencies[latencies.size() / 2];
        figures.p99 = latencies[latencies.size() * 99 / 100];
    }
    return figures;
}

class Isolation_test : public ::testing::TestWithParam<std::string> {};

TEST_P(Isolation_test, AHostileMonitorDelaysNothingButItsOwnConnection) {
    const std::string script = GetParam();
    TempDir dir;
    Daemon daemon(dir, "solo", "", hostile_daemon_flags(dir));
    {
        MonitoredBesideCalm connections(daemon, "hostile", script);

        // The hostile connection gets a message every 5 ms: its script is busy all the time.
        PacedWriter hostile(connections.monitored_out, 5ms);
        ASSERT_TRUE(eventually([&] {
            auto stats = json::parse(run_cli(dir, daemon, {"stats", "/hostile/in", "--json"}).out);
            return stats["ports"][0]["inbound"][0]["monitors"][0]["errors"].get<std::uint64_t>() >= 2;
        })) << script
            << ": the hostile calls were not stopped and counted";

        // Meanwhile, a 500 Hz stream on the other connection.
        const auto calm = measure_calm(connections.calm_out, connections.calm_in);
        ASSERT_EQ(calm.delivered, 1000u) << script << ": the calm connection stopped delivering";

        const auto asked = Clock::now();
        auto listed = run_cli(dir, daemon, {"list"});
        const double list_ms = ms(Clock::now() - asked);
        EXPECT_EQ(listed.status, 0) << listed.err;

        auto stats = json::parse(run_cli(dir, daemon, {"stats", "/hostile/in", "--json"}).out);
        const auto monitor = stats["ports"][0]["inbound"][0]["monitors"][0];
        std::cout << "  " << script << ": calm p50 " << calm.p50 << " ms, p99 " << calm.p99
                  << " ms; plexus list " << list_ms << " ms; hostile calls " << monitor["messages"]
                  << ", errors " << monitor["errors"] << " (timeouts " << monitor["timeouts"]
                  << ", out of memory " << monitor["out_of_memory"] << ")\n";
        EXPECT_LT(calm.p99, 5.0 * slowdown()) << script;
        EXPECT_LT(list_ms, 1000.0 * slowdown()) << script;
        EXPECT_GE(monitor["errors"].get<std::uint64_t>(), 2u);
        EXPECT_EQ(monitor["quarantined"], false);
        // Its first call ran inline on the daemon's thread (a stage starts there) and overran: the
        // stand-in took the event loop over, and the monitor went to a worker for good.
        const auto inbound = stats["ports"][0]["inbound"][0];
        EXPECT_GE(inbound["monitor_inline_overruns"].get<std::uint64_t>(), 1u) << script;
        EXPECT_EQ(inbound["monitors_inline"], false) << script;
        hostile.stop();
    }
    // SIGTERM while the script may still be inside a call.
    const auto asked = Clock::now();
    daemon.process().signal(SIGTERM);
    const auto status = daemon.process().wait(slower(std::chrono::milliseconds(2000)));
    const double stop_ms = ms(Clock::now() - asked);
    std::cout << "  " << script << ": SIGTERM to exit " << stop_ms << " ms\n";
    ASSERT_TRUE(status.has_value()) << script << ": the daemon did not stop within 2 s of SIGTERM";
}

// One of each kind: a pure Lua busy loop, a pattern inside the string library, a comparator called
// from C, the memory cap.
INSTANTIATE_TEST_SUITE_P(Hostile, Isolation_test,
                         ::testing::Values("busy_loop", "pattern_find", "sort_slow_comparator",
                                           "rep_to_cap"));

TEST(Isolation_test, AHostileSendMonitorOnAnMcastConnectionDelaysNothingElse) {
    // The send-side monitors of mcast are the port's, run once per message for all its mcast
    // connections: they too run on a worker, not on the daemon's thread.
    PLEXUS_NEEDS_NETNS();
    Network net(3);
    TempDir dir;
    NameServerProcess names(dir, net.host(0));
    Daemon writer_side(dir, net.host(1), "writer", names.address(), hostile_daemon_flags(dir));
    Daemon reader_side(dir, net.host(2), "reader", names.address(), hostile_daemon_flags(dir));
    auto reader = start_cli(dir, reader_side, {"read", "/hostile/in", "--timeout", "60"}, "hostile-reader");
    ASSERT_TRUE(wait_port(dir, writer_side, "/hostile/in"));
    Client::Options options;
    options.socket = writer_side.socket();
    Client client(options);
    auto hostile_out = client.open("/hostile/out");
    auto calm_out = client.open("/calm/out");
    auto calm_in = client.open("/calm/in");
    client.connect("/hostile/out", "/hostile/in", "mcast+send.portmonitor+type.lua+file.busy_loop");
    client.connect("/calm/out", "/calm/in", "local");

    PacedWriter hostile(hostile_out, 5ms);
    json monitor;
    ASSERT_TRUE(eventually([&] {
        auto stats = json::parse(run_cli(dir, writer_side, {"stats", "/hostile/out", "--json"}).out);
        monitor = stats["ports"][0]["outgoing"][0]["monitors"][0];
        return monitor.is_object() && monitor["errors"].get<std::uint64_t>() >= 2;
    })) << "the hostile send-side calls were not stopped and counted: "
        << monitor.dump();

    constexpr std::uint64_t count = 1000;
    PacedWriter calm(calm_out, 2ms, count);
    const auto latencies = calm_latencies(calm_in, count);
    ASSERT_EQ(latencies.size(), count) << "the calm connection stopped delivering";
    const double p99 = latencies[latencies.size() * 99 / 100];
    const auto asked = Clock::now();
    auto listed = run_cli(dir, writer_side, {"list"});
    const double list_ms = ms(Clock::now() - asked);
    std::cout << "  mcast send-side busy_loop: calm p50 " << latencies[latencies.size() / 2] << " ms, p99 "
              << p99 << " ms; plexus list " << list_ms << " ms\n";
    EXPECT_LT(p99, 5.0 * slowdown());
    EXPECT_EQ(listed.status, 0) << listed.err;
    EXPECT_LT(list_ms, 1000.0 * slowdown());
    hostile.stop();
    reader->signal(SIGTERM);
}

TEST(Isolation_test, AScriptThatOverrunsNowAndThenHandsTheLoopOverEachTimeAndDelaysNothingElse) {
    // Cheap but for every 300th message (30 ms then, at 1 kHz: without the stand-in, the other
    // connection's messages would wait for it one time in ten). Each time it overruns inline, the
    // stand-in takes the event loop over; the stage goes to a worker for a drain or two and comes
    // back (see the config below), and overruns again. Meanwhile another connection's latency
    // stays low.
    //
    // What the calm p99 tells apart: a tenth of the calm messages arrive during an overrun.
    // Without the stand-in they would wait the rest of it, so the p99 would be near 27 ms. With
    // it they wait for the hand-over (Stage::inline_overrun_after, 0.2 ms) and for a CPU: the
    // overrun keeps one of a 2-vCPU machine's two busy, and the stand-in, the writers, the reader
    // and its receiving thread share the other — up to 7 ms seen. Overruns of 10 ms under a 5 ms
    // bound (the first version) left no room between the two: CI failed at 5.86 ms, and 2 runs in 5
    // failed here.
    TempDir dir;
    std::ofstream(dir.file("now_and_then.lua")) << R"(
local n = 0
PortMonitor.accept = function(msg)
    n = n + 1
    if n % 300 == 0 then
        local start = PortMonitor.now()
        while PortMonitor.now() - start < 0.030 do end
    end
    return true
end
)";
    // Inline whatever the script costs between its overruns (100 ms a message): the default of
    // 10 us would put it on a worker for good in a sanitized build, where every call costs more.
    // And a budget above the overrun (the default, 20 ms, would end each as an error).
    const std::string config = dir.file("inline-always.json");
    std::ofstream(config) << R"({"monitor_inline_cost_us": 100000, "monitor_budget_ms": 100})";
    Daemon daemon(dir, "solo", "", {"--scripts", dir.path(), "--config", config});
    MonitoredBesideCalm connections(daemon, "odd", "now_and_then");
    PacedWriter odd(connections.monitored_out, 1ms);
    auto inbound_stats = [&] {
        return json::parse(
            run_cli(dir, daemon, {"stats", "/odd/in", "--json"}).out)["ports"][0]["inbound"][0];
    };
    ASSERT_TRUE(
        eventually([&] { return inbound_stats()["monitor_inline_overruns"].get<std::uint64_t>() >= 3; },
                   slower(std::chrono::milliseconds(30000))))
        << "the stage did not overrun inline, come back and overrun again";

    const auto calm = measure_calm(connections.calm_out, connections.calm_in);
    ASSERT_EQ(calm.delivered, 1000u) << "the calm connection stopped delivering";
    odd.stop();
    const auto inbound = inbound_stats();
    std::cout << "  now_and_then: calm p50 " << calm.p50 << " ms, p99 " << calm.p99 << " ms; inline overruns "
              << inbound["monitor_inline_overruns"] << ", odd messages " << inbound["received"] << ", errors "
              << inbound["monitors"][0]["errors"] << "\n";
    EXPECT_LT(calm.p99, 15.0 * slowdown());
    EXPECT_EQ(inbound["monitors"][0]["errors"], 0) << "an overrun must not be cut off: it is within budget";
}

TEST(Isolation_test, AHundredThousandMessagesThroughAMonitorArriveInOrderBesideOtherMonitors) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", hostile_daemon_flags(dir));
    Client::Options options;
    options.socket = daemon.socket();
    Client client(options);
    // Three monitored connections at once; the first is the one counted.
    std::vector<Port> outs;
    std::vector<Port> ins;
    for (int i = 0; i < 3; ++i) {
        outs.push_back(client.open("/order/out" + std::to_string(i)));
        ins.push_back(client.open("/order/in" + std::to_string(i)));
        client.connect("/order/out" + std::to_string(i), "/order/in" + std::to_string(i),
                       "local+recv.portmonitor+type.lua+file.certainty+threshold.-1");
    }
    constexpr std::uint64_t count = 100'000;
    std::atomic<bool> others_stop{false};
    std::vector<std::thread> others;
    for (int i = 1; i < 3; ++i) {
        others.emplace_back([&, i] {
            for (std::uint64_t n = 1; !others_stop; ++n)
                outs[i].write(Value{{"certainty", 1.0}, {"n", n}}, n % 64 == 0);
        });
    }
    std::thread drain_others([&] {
        while (!others_stop) {
            for (int i = 1; i < 3; ++i)
                ins[i].read(1ms);
        }
    });
    std::thread writer([&] {
        for (std::uint64_t n = 1; n <= count; ++n) {
            outs[0].write(Value{{"certainty", 1.0}, {"n", n}}, n % 64 == 0 || n == count);
        }
    });
    std::uint64_t expected = 1;
    bool in_order = true;
    const auto deadline = Clock::now() + slower(120s);
    while (expected <= count && Clock::now() < deadline) {
        auto message = ins[0].read(200ms);
        if (!message)
            continue;
        const auto n = message->data.at("n").get<std::uint64_t>();
        if (n != expected) {
            in_order = false;
            ADD_FAILURE() << "expected message " << expected << ", got " << n;
            break;
        }
        ++expected;
    }
    writer.join();
    others_stop = true;
    for (auto& other : others)
        other.join();
    drain_others.join();
    EXPECT_TRUE(in_order);
    EXPECT_EQ(expected - 1, count) << "messages lost or late";
    auto stats = json::parse(run_cli(dir, daemon, {"stats", "/order/in0", "--json"}).out);
    const auto inbound = stats["ports"][0]["inbound"][0];
    EXPECT_EQ(inbound["received"], count);
    EXPECT_EQ(inbound["delivered"], count);
    EXPECT_EQ(inbound["dropped_by_accept"], 0);
}

}  // namespace isolation_test
}  // namespace plexus::test
