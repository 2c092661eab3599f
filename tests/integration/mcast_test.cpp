// The mcast carrier on separate hosts (network namespaces): one send per message, whatever the
// number of receiving daemons.
#include <gtest/gtest.h>

#include "harness.hpp"
#include "netns.hpp"

namespace plexus::test {
namespace mcast_test {

using nlohmann::json;

json stats_of(const TempDir& dir, const Daemon& daemon, const std::string& port = "") {
    std::vector<std::string> args{"stats", "--json"};
    if (!port.empty())
        args.insert(args.begin() + 1, port);
    auto stats = run_cli(dir, daemon, args);
    return stats.status == 0 ? json::parse(stats.out) : json();
}

TEST(Mcast_test, EveryMessageIsSentOnceToReadersOnThreeHostsWithAMonitorOnEachSide) {
    PLEXUS_NEEDS_NETNS();
    Network net(5);
    TempDir dir;
    NameServerProcess names(dir, net.host(0));
    const std::vector<std::string> scripts{"--scripts", monitors_dir()};
    Daemon writer_side(dir, net.host(1), "writer", names.address(), scripts);
    std::vector<std::unique_ptr<Daemon>> readers_sides;
    std::vector<std::unique_ptr<Process>> readers;
    const int count = 100;
    for (int k = 2; k <= 4; ++k) {
        readers_sides.push_back(std::make_unique<Daemon>(dir, net.host(k), "reader" + std::to_string(k),
                                                         names.address(), scripts));
        readers.push_back(start_cli(dir, *readers_sides.back(),
                                    {"read", "/r" + std::to_string(k) + "/in", "--timeout", "60"},
                                    "cli-reader" + std::to_string(k)));
    }
    CliWriter writer(dir, writer_side, "/a/out", "writer");
    // The writer opens its port as it starts: connecting before that finds no /a/out.
    ASSERT_TRUE(wait_port(dir, writer_side, "/a/out"));
    for (int k = 2; k <= 4; ++k) {
        const std::string port = "/r" + std::to_string(k) + "/in";
        ASSERT_TRUE(wait_port(dir, writer_side, port));
        auto connected =
            run_cli(dir, writer_side,
                    {"connect", "/a/out", port,
                     "mcast+send.portmonitor+type.lua+file.rate_logger+recv.portmonitor+type.lua+file."
                     "rate_logger"});
        ASSERT_EQ(connected.status, 0) << connected.err;
    }
    const auto before = stats_of(dir, writer_side)["daemon"]["udp_datagrams_sent"].get<int>();

    writer.send(numbered_lines(0, count));

    for (std::size_t k = 0; k < readers.size(); ++k) {
        auto& reader = readers[k];
        ASSERT_TRUE(eventually([&] { return reader->out() == numbered_lines(0, count); }, 30s))
            << "reader on host " << k + 2 << " got [" << reader->out() << "]\n"
            << stats_of(dir, *readers_sides[k]).dump() << "\n"
            << stats_of(dir, writer_side).dump();
    }
    // One send per message: the writer's daemon sent `count` datagrams (each message fits one),
    // not three times as many.
    const auto writer_stats = stats_of(dir, writer_side, "/a/out");
    EXPECT_EQ(writer_stats["daemon"]["udp_datagrams_sent"].get<int>() - before, count) << writer_stats.dump();
    for (const auto& connection : writer_stats["ports"][0]["outgoing"]) {
        EXPECT_EQ(connection["mcast"]["messages_sent_once"], count) << connection.dump();
        EXPECT_EQ(connection["sent"], count);
        // The shared send-side monitor saw each message once.
        EXPECT_EQ(connection["monitors"][0]["messages"], count) << connection.dump();
    }
    // `plexus param` reaches the shared send-side monitor (on its worker) and the receiving one.
    auto param = run_cli(dir, writer_side, {"param", "get", "/a/out", "/r2/in"});
    ASSERT_EQ(param.status, 0) << param.err;
    const auto sides = json::parse(param.out);
    ASSERT_EQ(sides.size(), 2u) << param.out;
    EXPECT_EQ(sides[0]["side"], "send") << param.out;
    EXPECT_EQ(sides[1]["side"], "recv") << param.out;
    for (int k = 2; k <= 4; ++k) {
        const std::string port = "/r" + std::to_string(k) + "/in";
        const auto stats = stats_of(dir, *readers_sides[k - 2], port);
        const auto& inbound = stats["ports"][0]["inbound"][0];
        EXPECT_EQ(inbound["received"], count) << stats.dump();
        EXPECT_EQ(inbound["lost"], 0) << stats.dump();
        EXPECT_EQ(inbound["monitors"][0]["messages"], count) << stats.dump();
    }
    EXPECT_EQ(writer.finish(), 0) << writer.process().err();
}

TEST(Mcast_test, MonitorsOfOnePortsMcastConnectionsMustAgree) {
    PLEXUS_NEEDS_NETNS();
    Network net(3);
    TempDir dir;
    NameServerProcess names(dir, net.host(0));
    const std::vector<std::string> scripts{"--scripts", monitors_dir()};
    Daemon writer_side(dir, net.host(1), "writer", names.address(), scripts);
    Daemon reader_side(dir, net.host(2), "reader", names.address(), scripts);
    auto first = start_cli(dir, reader_side, {"read", "/r/one", "--timeout", "30"}, "one");
    auto second = start_cli(dir, reader_side, {"read", "/r/two", "--timeout", "30"}, "two");
    CliWriter writer(dir, writer_side, "/a/out", "writer");
    ASSERT_TRUE(wait_port(dir, writer_side, "/r/one") && wait_port(dir, writer_side, "/r/two"));
    auto with = run_cli(dir, writer_side,
                        {"connect", "/a/out", "/r/one", "mcast+send.portmonitor+type.lua+file.rate_logger"});
    ASSERT_EQ(with.status, 0) << with.err;
    auto without = run_cli(dir, writer_side, {"connect", "/a/out", "/r/two", "mcast"});
    EXPECT_EQ(without.status, 4);
    EXPECT_NE(without.err.find("share one stream"), std::string::npos) << without.err;
    EXPECT_EQ(writer.finish(), 0) << writer.process().err();
}

}  // namespace mcast_test
}  // namespace plexus::test
