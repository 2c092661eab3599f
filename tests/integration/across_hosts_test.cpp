// Carriers and discovery between daemons on separate hosts (network namespaces, see netns.hpp):
// udp with monitors on both sides, and daemons and the CLI finding the name server by themselves.
#include <gtest/gtest.h>

#include "harness.hpp"
#include "netns.hpp"

namespace plexus::test {
namespace across_hosts_test {

using nlohmann::json;

TEST(AcrossHosts_test, UdpCarriesMessagesWithAMonitorOnEachSide) {
    PLEXUS_NEEDS_NETNS();
    Network net(3);
    TempDir dir;
    NameServerProcess names(dir, net.host(0));
    Daemon writer_side(dir, net.host(1), "one", names.address(), {"--scripts", monitors_dir()});
    Daemon reader_side(dir, net.host(2), "two", names.address(), {"--scripts", monitors_dir()});

    const int count = 100;
    auto reader = start_cli(dir, reader_side, {"read", "/b/in", "--timeout", "60"}, "reader");
    CliWriter writer(dir, writer_side, "/a/out", "writer");
    ASSERT_TRUE(wait_port(dir, writer_side, "/a/out"));
    ASSERT_TRUE(wait_port(dir, writer_side, "/b/in"));
    const std::string carrier =
        "udp+send.portmonitor+type.lua+file.rate_logger+recv.portmonitor+type.lua+file.rate_logger";
    auto connected = run_cli(dir, writer_side, {"connect", "/a/out", "/b/in", carrier});
    ASSERT_EQ(connected.status, 0) << connected.err;

    writer.send(numbered_lines(0, count));

    ASSERT_TRUE(eventually([&] { return reader->out() == numbered_lines(0, count); }, 30s)) << reader->out();
    // Each monitor ran where it belongs and saw every message.
    for (const auto* side : {&writer_side, &reader_side}) {
        auto param = run_cli(dir, *side, {"param", "get", "/a/out", "/b/in"});
        ASSERT_EQ(param.status, 0) << param.err;
        const auto monitors = json::parse(param.out);
        ASSERT_EQ(monitors.size(), 2u) << param.out;
        for (const auto& monitor : monitors)
            EXPECT_EQ(monitor["param"]["messages"], count) << param.out;
    }
    const auto inbound = inbound_stats(dir, reader_side, "/b/in", "/a/out");
    ASSERT_FALSE(inbound.is_null()) << run_cli(dir, reader_side, {"stats", "/b/in", "--json"}).out;
    EXPECT_EQ(inbound["lost"], 0);
    EXPECT_EQ(inbound["late"], 0);
    EXPECT_EQ(inbound["received"], count);
    EXPECT_EQ(writer.finish(), 0) << writer.process().err();
}

TEST(AcrossHosts_test, DaemonsAndTheCliFindTheNameServerWithNoConfiguration) {
    PLEXUS_NEEDS_NETNS();
    Network net(4);
    TempDir dir;
    NameServerProcess names(dir, net.host(0));
    std::vector<std::unique_ptr<Daemon>> daemons;
    for (int k = 1; k <= 3; ++k) {
        daemons.push_back(
            std::make_unique<Daemon>(dir, net.host(k), "node" + std::to_string(k), discover_names));
        EXPECT_EQ(daemons.back()->names(), names.address());
    }
    for (const auto& daemon : daemons) {
        auto where = run_cli(dir, *daemon, {"where"});
        ASSERT_EQ(where.status, 0) << where.err;
        EXPECT_EQ(where.out.rfind(names.address() + " (found by multicast discovery on ", 0), 0u)
            << where.out;
    }
    // And the system works: a reader on host 3 gets what host 1 writes.
    auto reader =
        start_cli(dir, *daemons[2], {"read", "/c/in", "--count", "20", "--timeout", "60"}, "reader");
    ASSERT_TRUE(wait_port(dir, *daemons[0], "/c/in"));
    auto written = run_cli(dir, *daemons[0], {"write", "/a/out", "/c/in"}, numbered_lines(0, 20));
    ASSERT_EQ(written.status, 0) << written.err;
    ASSERT_EQ(reader->wait(60s), 0) << reader->err();
    EXPECT_EQ(reader->out(), numbered_lines(0, 20));
}

TEST(AcrossHosts_test, WithNoNameServerToFindTheDefaultIsUsedAndSaidSo) {
    PLEXUS_NEEDS_NETNS();
    Network net(2);  // no name server anywhere on it
    TempDir dir;
    Process flagged(net.host(1).wrap({plexus_path(), "--names", "10.77.0.9:1", "where"}), {},
                    dir.file("flag"));
    ASSERT_EQ(flagged.wait(20s), 0) << flagged.err();
    EXPECT_EQ(flagged.out(), "10.77.0.9:1 (from --names)\n");
    Process asked(net.host(1).wrap({plexus_path(), "where"}), {}, dir.file("asked"));
    ASSERT_EQ(asked.wait(20s), 0) << asked.err();
    EXPECT_EQ(asked.out(), "127.0.0.1:10100 (the default; no name server answered on 239.255.80.88:10101)\n");
}

}  // namespace across_hosts_test
}  // namespace plexus::test
