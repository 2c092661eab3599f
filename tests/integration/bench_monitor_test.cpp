// `plexus-bench monitor` and `monitor-latency` run their variants end to end and prints one JSON row per
// system with the keys of `plexus-bench throughput`. The figures are not judged here (speed is for the
// bench).
#include <gtest/gtest.h>

#include <set>

#include "harness.hpp"

namespace plexus::test {
namespace bench_monitor_test {

/// Runs plexus-bench with `arguments` (--json among them) to its end; its rows, none if it failed.
std::vector<nlohmann::json> bench_rows(const std::vector<std::string>& arguments) {
    TempDir dir;
    std::vector<std::string> command{PLEXUS_BENCH_PATH};
    command.insert(command.end(), arguments.begin(), arguments.end());
    Process bench(command, {}, dir.file("bench"));
    const auto status = bench.wait(std::chrono::seconds(120));
    EXPECT_TRUE(status.has_value()) << "the bench did not finish";
    EXPECT_EQ(status.value_or(-1), 0) << bench.err();
    if (status != 0)
        return {};
    return json_lines(bench.out());
}

TEST(BenchMonitor_test, EveryVariantRunsAndPrintsItsRow) {
    std::set<std::string> systems;
    for (const auto& row :
         bench_rows({"monitor", "--json", "--count", "2000", "--repeat", "1", "--empty-accept"})) {
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
    std::set<std::string> systems;
    for (const auto& row : bench_rows({"monitor-latency", "--json", "--count", "500", "--repeat", "1"})) {
        EXPECT_EQ(row.at("scenario"), "monitor_latency_1hop");
        EXPECT_GT(row.at("msgs_per_s").get<double>(), 0) << row.dump();
        systems.insert(row.at("system").get<std::string>());
    }
    EXPECT_EQ(systems, (std::set<std::string>{"none", "accept_inline", "accept_on_worker"}));
}

TEST(BenchStreams_test, EveryRowDeliversItsStreamsAndSaysWhatTheDaemonSpent) {
    std::set<std::pair<int, int>> rows;  // (--threads, streams)
    for (const auto& row : bench_rows({"streams", "--json", "--streams", "1,3,40", "--clients", "4",
                                       "--count", "4000", "--repeat", "1", "--daemon-threads", "1,2"})) {
        for (const char* key : {"scenario", "threads", "streams", "msgs_per_s", "against_first",
                                "against_first_daemon", "cpu_us_per_msg", "daemon_cpu_us_per_msg"})
            EXPECT_TRUE(row.contains(key)) << key << " missing in " << row.dump();
        EXPECT_EQ(row.at("scenario"), "streams");
        EXPECT_GT(row.at("msgs_per_s").get<double>(), 0) << row.dump();
        EXPECT_GE(row.at("cpu_us_per_msg").get<double>(), row.at("daemon_cpu_us_per_msg").get<double>())
            << row.dump();
        rows.insert({row.at("threads").get<int>(), row.at("streams").get<int>()});
    }
    EXPECT_EQ(rows, (std::set<std::pair<int, int>>{{1, 1}, {1, 3}, {1, 40}, {2, 1}, {2, 3}, {2, 40}}));
}

}  // namespace bench_monitor_test
}  // namespace plexus::test
