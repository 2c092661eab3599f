// `plexus-bench monitor` and `monitor-latency` run their variants end to end and prints one JSON row per
// system with the keys of `plexus-bench throughput`. The figures are not judged here (speed is for the
// bench).
#include <gtest/gtest.h>

#include <set>

#include "harness.hpp"

namespace plexus::test {
namespace {

TEST(BenchMonitor_test, EveryVariantRunsAndPrintsItsRow) {
    TempDir dir;
    Process bench(
        {PLEXUS_BENCH_PATH, "monitor", "--json", "--count", "2000", "--repeat", "1", "--empty-accept"}, {},
        dir.file("bench"));
    const auto status = bench.wait(std::chrono::seconds(120));
    ASSERT_TRUE(status.has_value()) << "the bench did not finish";
    ASSERT_EQ(*status, 0) << bench.err();

    std::set<std::string> systems;
    for (const auto& row : json_lines(bench.out())) {
        for (const char* key : {"system", "scenario", "size", "msgs_per_s", "cpu_us_per_msg"})
            EXPECT_TRUE(row.contains(key)) << key << " missing in " << row.dump();
        EXPECT_EQ(row.at("scenario"), "monitor_1hop");
        EXPECT_GT(row.at("msgs_per_s").get<double>(), 0) << row.dump();
        systems.insert(row.at("system").get<std::string>());
    }
    EXPECT_EQ(systems, (std::set<std::string>{"none", "accept_one_field", "update_rewrite", "accept_empty"}));
}

TEST(BenchMonitor_test, MonitorLatencyMeasuresInlineAndOnAWorkerBesideNone) {
    // Two daemons, one with --no-inline-monitors: the worker row must come from a daemon that runs
    // (an unknown flag would end the bench here, not in a user's hands).
    TempDir dir;
    Process bench({PLEXUS_BENCH_PATH, "monitor-latency", "--json", "--count", "500", "--repeat", "1"}, {},
                  dir.file("bench"));
    const auto status = bench.wait(std::chrono::seconds(120));
    ASSERT_TRUE(status.has_value()) << "the bench did not finish";
    ASSERT_EQ(*status, 0) << bench.err();
    std::set<std::string> systems;
    for (const auto& row : json_lines(bench.out())) {
        EXPECT_EQ(row.at("scenario"), "monitor_latency_1hop");
        EXPECT_GT(row.at("msgs_per_s").get<double>(), 0) << row.dump();
        systems.insert(row.at("system").get<std::string>());
    }
    EXPECT_EQ(systems, (std::set<std::string>{"none", "accept_inline", "accept_on_worker"}));
}

}  // namespace
}  // namespace plexus::test
