// `plexus-bench hosts --quick` builds its hosts (network namespaces), runs every part end to end
// and prints its JSON rows. The figures are not judged here (speed is for the bench), except what
// does not depend on the machine: mcast puts one copy of each message on the writer's wire.
#include <gtest/gtest.h>

#include <set>

#include "harness.hpp"
#include "netns.hpp"

namespace plexus::test {
namespace bench_hosts_test {

TEST(BenchHosts_test, EveryPartRunsAndMcastSendsOneCopy) {
    PLEXUS_NEEDS_NETNS();
    TempDir dir;
    Process bench({PLEXUS_BENCH_PATH, "hosts", "--quick", "--json"}, {}, dir.file("bench"));
    const auto status = bench.wait(std::chrono::seconds(120));
    ASSERT_TRUE(status.has_value()) << "the bench did not finish";
    if (*status == 77)  // hosts_unavailable_status: this machine cannot make namespaces
        GTEST_SKIP() << bench.err();
    ASSERT_EQ(*status, 0) << bench.err();

    std::set<std::string> seen;
    for (const auto& row : json_lines(bench.out())) {
        const std::string scenario = row.at("scenario");
        seen.insert(scenario + " " + row.value("carrier", "") + " " + row.at("system").get<std::string>());
        if (scenario == "hosts_latency" || scenario == "hosts_throughput") {
            EXPECT_GT(row.at("msgs_per_s").get<double>(), 0) << row.dump();
            EXPECT_GT(row.at("p50_us").get<double>(), 0) << row.dump();
        } else if (scenario == "hosts_fanout") {
            EXPECT_EQ(row.at("lost"), 0) << row.dump();
            if (row.at("carrier") == "mcast") {
                // Every datagram the writer's daemon sent went out once, not once per receiver.
                EXPECT_NEAR(row.at("wire_packets_per_msg").get<double>(),
                            row.at("datagrams_per_msg").get<double>(),
                            0.1 * row.at("datagrams_per_msg").get<double>())
                    << row.dump();
            }
        } else if (scenario == "hosts_connect") {
            EXPECT_GT(row.at("p50_ms").get<double>(), 0) << row.dump();
        }
    }
    for (const std::string carrier : {"tcp", "udp", "mcast"}) {
        for (const std::string scenario : {"hosts_latency", "hosts_throughput"}) {
            EXPECT_TRUE(seen.count(scenario + " " + carrier + " plexus")) << scenario << " " << carrier;
            EXPECT_TRUE(seen.count(scenario + " " + carrier + " floor")) << scenario << " " << carrier;
        }
    }
    EXPECT_TRUE(seen.count("hosts_latency udp plexus_insecure"));
    EXPECT_TRUE(seen.count("hosts_fanout mcast plexus"));
    EXPECT_TRUE(seen.count("hosts_fanout tcp plexus"));
    EXPECT_TRUE(seen.count("hosts_connect tcp plexus"));
    EXPECT_TRUE(seen.count("hosts_connect tcp plexus_insecure"));
}

}  // namespace bench_hosts_test
}  // namespace plexus::test
