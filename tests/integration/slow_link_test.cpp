// A slow network between two hosts (tc tbf at 10 Mbit/s on the writer's host, small TCP buffers):
// into a `strict` port the writer is slowed to the network's pace and loses nothing; into a
// `latest` port the reader gets recent data, however far ahead the writer is.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>

#include "harness.hpp"
#include "netns.hpp"

namespace plexus::test {
namespace slow_link_test {

using nlohmann::json;
using SteadyClock = std::chrono::steady_clock;

constexpr int message_bytes = 1000;
constexpr double link_bits_per_second = 10e6;

/// `count` JSON strings of ~1000 bytes, each ending in its number.
std::string big_lines(int count) {
    std::string lines;
    const std::string padding(message_bytes - 8, 'x');
    for (int i = 0; i < count; ++i)
        lines += "\"" + padding + std::to_string(i) + "\"\n";
    return lines;
}

class SlowLink_test : public ::testing::Test {
protected:
    void SetUp() override {
        PLEXUS_NEEDS_NETNS();
        net = std::make_unique<Network>(3);
        // Small TCP buffers on both hosts, so that what waits in the network is the daemons'
        // business (their queues), not seconds of kernel buffers at 10 Mbit/s.
        for (int k = 1; k <= 2; ++k) {
            net->host(k).run_checked(
                "sysctl -q -w net.ipv4.tcp_wmem='4096 16384 65536' "
                "net.ipv4.tcp_rmem='4096 65536 131072'");
        }
        net->host(1).run_checked("tc qdisc add dev eth0 root tbf rate 10mbit burst 32kbit latency 50ms");
        config = dir.file("small-links.json");
        std::ofstream(config) << R"({"link_capacity": 64})";
        names = std::make_unique<NameServerProcess>(dir, net->host(0));
        writer_side = std::make_unique<Daemon>(dir, net->host(1), "one", names->address(),
                                               std::vector<std::string>{"--config", config});
        reader_side = std::make_unique<Daemon>(dir, net->host(2), "two", names->address());
    }
    std::unique_ptr<Network> net;
    TempDir dir;
    std::string config;
    std::unique_ptr<NameServerProcess> names;
    std::unique_ptr<Daemon> writer_side;
    std::unique_ptr<Daemon> reader_side;
};

TEST_F(SlowLink_test, StrictSlowsTheWriterToTheLinkAndLosesNothing) {
    const int count = 2000;  // 2 MB: 1.6 s at 10 Mbit/s
    auto reader =
        start_cli(dir, *reader_side,
                  {"read", "/b/in", "--count", std::to_string(count), "--queue", "64", "--timeout", "60"},
                  "cli-reader");
    ASSERT_TRUE(wait_port(dir, *writer_side, "/b/in")) << reader->err() << reader_side->process().out();
    const auto start = SteadyClock::now();
    auto written = run_cli(dir, *writer_side, {"write", "/a/out", "/b/in"}, big_lines(count));
    const double writing = std::chrono::duration<double>(SteadyClock::now() - start).count();
    ASSERT_EQ(written.status, 0) << written.err;
    ASSERT_EQ(reader->wait(60s), 0) << reader->err();
    EXPECT_EQ(reader->out(), big_lines(count));  // all of it, in order
    // The writer could not run ahead by more than the queues and buffers between it and the
    // reader hold (well under 1 MB here), so it took at least the time the rest needs on the link.
    const double bound = (count * message_bytes - 1e6) * 8 / link_bits_per_second;
    std::cout << "strict: " << count << " messages written in " << writing << " s (link time "
              << count * message_bytes * 8 / link_bits_per_second << " s)\n";
    EXPECT_GE(writing, bound);
}

TEST_F(SlowLink_test, LatestKeepsTheReadersLatencyBounded) {
    // 4 MB: 3.2 s of link time, written far faster. A slower build (slowdown(), harness.hpp) may
    // take longer to hand the last message on, so its latency bound is stretched; the volume is
    // stretched as much, so that queueing everything would still overshoot the bound threefold.
    const int count = static_cast<int>(4000 * slowdown());
    const double latency_bound = 1.0 * slowdown();
    auto reader =
        start_cli(dir, *reader_side,
                  {"read", "/b/in", "--policy", "latest", "--queue", "4", "--envelope", "--timeout", "60"},
                  "cli-reader");
    ASSERT_TRUE(wait_port(dir, *writer_side, "/b/in")) << reader->err() << reader_side->process().out();
    CliWriter writer(dir, *writer_side, "/a/out", "cli-writer");
    ASSERT_TRUE(wait_port(dir, *writer_side, "/a/out"));
    auto connected = run_cli(dir, *writer_side, {"connect", "/a/out", "/b/in", "tcp"});
    ASSERT_EQ(connected.status, 0) << connected.err;
    writer.send(big_lines(count));
    // The last message arrives soon after it was written: the link dropped what the network
    // could not carry instead of queueing seconds of it.
    json arrived;
    ASSERT_TRUE(eventually(
        [&] {
            for (const auto& line : json_lines(reader->out())) {
                if (line["data"].get<std::string>().ends_with(std::to_string(count - 1)))
                    arrived = line;
            }
            return !arrived.is_null();
        },
        60s));
    // Both clocks are this machine's (the hosts are namespaces of one kernel); "time" is in seconds.
    const double now =
        std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    const double latency = now - arrived["time"].get<double>();
    const auto lines = json_lines(reader->out());
    std::cout << "latest: " << lines.size() << " of " << count << " messages read; the last " << latency
              << " s after it was written\n";
    EXPECT_LT(latency, latency_bound);
    EXPECT_LT(lines.size(), static_cast<std::size_t>(count));  // the rest was dropped, not queued
    auto stats = run_cli(dir, *writer_side, {"stats", "/a/out", "--json"});
    ASSERT_EQ(stats.status, 0) << stats.err;
    EXPECT_GT(json::parse(stats.out)["ports"][0]["outgoing"][0]["dropped_latest"].get<int>(), 0) << stats.out;
    EXPECT_EQ(writer.finish(), 0) << writer.process().err();
}

}  // namespace slow_link_test
}  // namespace plexus::test
