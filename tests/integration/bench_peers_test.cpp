// `plexus-bench peers` does every job end to end on Plexus and prints rows with the contract's
// keys. The peers are optional (scripts/bench-peers-setup) and not on a CI machine: their test runs
// only where the bench was built with them (-DPLEXUS_BENCH_PEERS=ON), and skips saying why otherwise.
// The figures themselves are not judged here: speed is measured by the bench, not by tests.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <set>
#include <thread>
#include <tuple>

#include "harness.hpp"

namespace plexus::test {
namespace bench_peers_test {

TEST(BenchPeers_test, EveryScenarioAndSizeRunsOnPlexusWithoutLoss) {
    TempDir dir;
    Process bench({PLEXUS_BENCH_PATH, "peers", "--systems", "plexus,plexus-loans", "--json", "--quick",
                   "--count", "40", "--sizes", "64,4096,1048576"},
                  {}, dir.file("bench"));
    const auto status = bench.wait(std::chrono::seconds(240));
    ASSERT_TRUE(status.has_value()) << "the bench did not finish";
    ASSERT_EQ(*status, 0) << bench.err();

    const auto rows = json_lines(bench.out());
    std::set<std::tuple<std::string, std::string, std::size_t>> seen;
    for (const auto& row : rows) {
        for (const char* key : {"system", "scenario", "size", "p50_us", "p99_us", "p999_us", "msgs_per_s",
                                "mb_per_s", "lost", "cpu_us_per_msg", "rss_mb"})
            EXPECT_TRUE(row.contains(key)) << key << " missing in " << row.dump();
        EXPECT_EQ(row.at("lost"), 0) << "Plexus's strict queues must not lose: " << row.dump();
        EXPECT_GT(row.at("msgs_per_s").get<double>(), 0) << row.dump();
        EXPECT_GT(row.at("p50_us").get<double>(), 0) << row.dump();
        EXPECT_LE(row.at("p50_us").get<double>(), row.at("p99_us").get<double>()) << row.dump();
        EXPECT_GT(row.at("rss_mb").get<double>(), 0) << row.dump();
        seen.emplace(row.at("system").get<std::string>(), row.at("scenario").get<std::string>(),
                     row.at("size").get<std::size_t>());
    }
    EXPECT_EQ(seen.size(), rows.size()) << "a row came twice or from another system";
    for (const char* system : {"plexus", "plexus-loans"}) {
        for (const char* scenario : {"pingpong", "rate_1khz", "throughput", "fanout_8"}) {
            for (const std::size_t size : {64u, 4096u, 1048576u})
                EXPECT_TRUE(seen.count({system, scenario, size}))
                    << system << " " << scenario << " " << size << " missing";
        }
    }
}

#ifdef PLEXUS_BENCH_PEERS
/// True while a RouDi holds iceoryx's machine-wide lock.
bool roudi_running() {
    const int fd = ::open("/tmp/iox-unique-roudi.lock", O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return false;
    const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0;
    ::close(fd);
    return held;
}
#endif

// DDS and iceoryx: the same jobs and keys, every hop between two processes (the far ends), and
// nothing left behind: the runs' RouDis gone and their shared memory removed.
TEST(BenchPeers_test, CycloneDdsAndIceoryxDoEveryJobAndLeaveNothingBehind) {
#ifndef PLEXUS_BENCH_PEERS
    GTEST_SKIP() << "the bench was built without the peers (-DPLEXUS_BENCH_PEERS=ON, "
                    "scripts/bench-peers-setup): no DDS or iceoryx driver to run";
#else
    if (::geteuid() != 0)
        GTEST_SKIP() << "the DDS runs make a network namespace of their own, which needs root";
    if (roudi_running())
        GTEST_SKIP()
            << "another iceoryx RouDi is running on this machine; the bench refuses to run beside it";
    TempDir dir;
    Process bench({PLEXUS_BENCH_PATH, "peers", "--systems", "cyclonedds,cyclonedds-be,iceoryx", "--json",
                   "--quick", "--count", "40", "--sizes", "64,1048576"},
                  {}, dir.file("bench"));
    const auto status = bench.wait(std::chrono::seconds(280));
    ASSERT_TRUE(status.has_value()) << "the bench did not finish";
    ASSERT_EQ(*status, 0) << bench.err();

    std::set<std::tuple<std::string, std::string, std::size_t>> seen;
    for (const auto& row : json_lines(bench.out())) {
        for (const char* key : {"system", "scenario", "size", "p50_us", "p99_us", "p999_us", "msgs_per_s",
                                "mb_per_s", "lost", "cpu_us_per_msg", "rss_mb"})
            EXPECT_TRUE(row.contains(key)) << key << " missing in " << row.dump();
        const auto system = row.at("system").get<std::string>();
        // Reliable DDS and iceoryx's blocking publishers lose nothing; best effort may.
        if (system != "cyclonedds-be") {
            EXPECT_EQ(row.at("lost"), 0) << row.dump();
        }
        EXPECT_GT(row.at("msgs_per_s").get<double>(), 0) << row.dump();
        EXPECT_GT(row.at("p50_us").get<double>(), 0) << row.dump();
        // iceoryx's RouDi is its server; DDS has none.
        if (system == "iceoryx") {
            EXPECT_GT(row.at("rss_mb").get<double>(), 0) << row.dump();
        } else {
            EXPECT_EQ(row.at("rss_mb").get<double>(), 0) << row.dump();
        }
        seen.emplace(system, row.at("scenario").get<std::string>(), row.at("size").get<std::size_t>());
    }
    for (const char* system : {"cyclonedds", "cyclonedds-be", "iceoryx"}) {
        for (const char* scenario : {"pingpong", "rate_1khz", "throughput", "fanout_8"}) {
            for (const std::size_t size : {64u, 1048576u})
                EXPECT_TRUE(seen.count({system, scenario, size})) << system << " " << scenario << " " << size;
        }
    }
    // The last run's RouDi stops once its run process has gone: give it a moment.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while ((roudi_running() || std::filesystem::exists("/dev/shm/iceoryx_mgmt")) &&
           std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));  // polling a condition with a deadline
    }
    EXPECT_FALSE(roudi_running()) << "a RouDi of the bench outlived it";
    EXPECT_FALSE(std::filesystem::exists("/dev/shm/iceoryx_mgmt")) << "RouDi's shared memory was left behind";
#endif
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

}  // namespace bench_peers_test
}  // namespace plexus::test
