// `plexus-bench calls` runs its calls end to end on one daemon and on two, each beside its floor,
// and prints what `latency` prints plus the mean. The figures are not judged here (speed is for the
// bench): only that every row is there and that each system measured something.
#include <gtest/gtest.h>

#include <set>

#include "harness.hpp"
#include "netns.hpp"

namespace plexus::test {
namespace bench_calls_test {

struct BenchRun {
    int status = -1;
    std::string out;
    std::string err;
};

BenchRun run_bench(const std::vector<std::string>& arguments) {
    TempDir dir;
    std::vector<std::string> command{PLEXUS_BENCH_PATH};
    command.insert(command.end(), arguments.begin(), arguments.end());
    Process bench(command, {}, dir.file("bench"));
    const auto status = bench.wait(std::chrono::seconds(120));
    EXPECT_TRUE(status.has_value()) << "the bench did not finish";
    return {status.value_or(-1), bench.out(), bench.err()};
}

TEST(BenchCalls_test, OneAndTwoHopsPrintAPlexusAndAFloorRow) {
    for (const std::string hops : {"1", "2"}) {
        SCOPED_TRACE(hops + " hop(s)");
        const auto run = run_bench({"calls", "--json", "--hops", hops, "--count", "50", "--repeat", "1"});
        ASSERT_EQ(run.status, 0) << run.err;
        std::set<std::string> systems;
        for (const auto& row : json_lines(run.out)) {
            EXPECT_EQ(row.at("scenario"), "calls_" + hops + "hop") << row.dump();
            EXPECT_EQ(row.at("size"), 64) << row.dump();
            for (const char* key : {"p50_us", "p99_us", "mean_us", "msgs_per_s"})
                EXPECT_GT(row.at(key).get<double>(), 0) << key << " in " << row.dump();
            systems.insert(row.at("system").get<std::string>());
        }
        EXPECT_EQ(systems, (std::set<std::string>{"plexus", "floor"}));
    }
}

TEST(BenchCalls_test, TableShowsRoundTripsAndTheRatioForABlob) {
    // 64 KiB: a call whose request and answer each take several socket reads.
    const auto run = run_bench({"calls", "--size", "65536", "--count", "20", "--repeat", "1"});
    ASSERT_EQ(run.status, 0) << run.err;
    for (const char* text :
         {"calls, 1 hop, 65536 B echoed: 20 calls per run", "plexus/floor", "p50 round trip (us)",
          "p99 round trip (us)", "mean round trip (us)", "messages/s (2 per call)"})
        EXPECT_NE(run.out.find(text), std::string::npos) << text << " missing in\n" << run.out;
}

TEST(BenchCalls_test, AcrossHostsEverySizeHasPlexusAndBothFloors) {
    PLEXUS_NEEDS_NETNS();
    const auto run = run_bench({"hosts", "--calls", "--quick", "--json"});
    if (run.status == 77)  // hosts_unavailable_status: this machine cannot make namespaces
        GTEST_SKIP() << run.err;
    ASSERT_EQ(run.status, 0) << run.err;
    std::set<std::string> seen;
    for (const auto& row : json_lines(run.out)) {
        EXPECT_EQ(row.at("scenario"), "hosts_calls") << row.dump();
        EXPECT_GT(row.at("p50_us").get<double>(), 0) << row.dump();
        seen.insert(std::to_string(row.at("size").get<std::size_t>()) + " " +
                    row.at("system").get<std::string>());
    }
    for (const std::string size : {"64", "65536", "1048576"}) {
        for (const std::string system : {"plexus", "relay_floor", "floor"})
            EXPECT_TRUE(seen.count(size + " " + system)) << size << " " << system;
    }
}

}  // namespace bench_calls_test
}  // namespace plexus::test
