// `plexus-bench peers` does every job end to end on Plexus and prints rows with the contract's
// keys. Only Plexus: the peers are optional (scripts/bench-peers-setup) and not on a CI machine.
// The figures themselves are not judged here: speed is measured by the bench, not by tests.
#include <gtest/gtest.h>

#include <set>

#include "harness.hpp"

namespace plexus::test {
namespace {

TEST(BenchPeers_test, EveryScenarioAndSizeRunsOnPlexusWithoutLoss) {
    TempDir dir;
    Process bench({PLEXUS_BENCH_PATH, "peers", "--systems", "plexus", "--json", "--quick", "--count", "40",
                   "--sizes", "64,4096,1048576"},
                  {}, dir.file("bench"));
    const auto status = bench.wait(std::chrono::seconds(240));
    ASSERT_TRUE(status.has_value()) << "the bench did not finish";
    ASSERT_EQ(*status, 0) << bench.err();

    const auto rows = json_lines(bench.out());
    std::set<std::pair<std::string, std::size_t>> seen;
    for (const auto& row : rows) {
        for (const char* key : {"system", "scenario", "size", "p50_us", "p99_us", "p999_us", "msgs_per_s",
                                "mb_per_s", "lost", "cpu_us_per_msg", "rss_mb"})
            EXPECT_TRUE(row.contains(key)) << key << " missing in " << row.dump();
        EXPECT_EQ(row.at("system"), "plexus");
        EXPECT_EQ(row.at("lost"), 0) << "Plexus's strict queues must not lose: " << row.dump();
        EXPECT_GT(row.at("msgs_per_s").get<double>(), 0) << row.dump();
        EXPECT_GT(row.at("p50_us").get<double>(), 0) << row.dump();
        EXPECT_LE(row.at("p50_us").get<double>(), row.at("p99_us").get<double>()) << row.dump();
        EXPECT_GT(row.at("rss_mb").get<double>(), 0) << row.dump();
        seen.emplace(row.at("scenario").get<std::string>(), row.at("size").get<std::size_t>());
    }
    for (const char* scenario : {"pingpong", "rate_1khz", "throughput", "fanout_8"}) {
        for (const std::size_t size : {64u, 4096u, 1048576u})
            EXPECT_TRUE(seen.count({scenario, size})) << scenario << " " << size << " missing";
    }
}

TEST(BenchPeers_test, AnUnknownSystemIsRefusedNamingWhatIsBuilt) {
    TempDir dir;
    Process bench({PLEXUS_BENCH_PATH, "peers", "--systems", "kafka", "--quick"}, {}, dir.file("bench"));
    const auto status = bench.wait(std::chrono::seconds(30));
    ASSERT_TRUE(status.has_value());
    EXPECT_NE(*status, 0);
    EXPECT_NE(bench.err().find("unknown or not built system 'kafka'"), std::string::npos) << bench.err();
    EXPECT_NE(bench.err().find("plexus"), std::string::npos) << bench.err();
}

}  // namespace
}  // namespace plexus::test
