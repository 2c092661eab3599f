// `plexus-bench bridges` measures both paths of both bridges end to end in its own namespace and
// prints one row per link and size. The figures are not judged here (speed is for the bench): only
// that every row is there, that each path measured something and that nothing was lost.
#include <gtest/gtest.h>

#include <set>

#include "harness.hpp"
#include "netns.hpp"

namespace plexus::test {
namespace bench_bridges_test {

TEST(BenchBridges_test, EveryLinkAndSizeHasADirectAndABridgedFigure) {
    PLEXUS_NEEDS_NETNS();
    TempDir dir;
    Process bench({PLEXUS_BENCH_PATH, "bridges", "--quick", "--json", "--sizes", "64,65536"}, {},
                  dir.file("bench"));
    const auto status = bench.wait(std::chrono::seconds(240));
    ASSERT_TRUE(status.has_value()) << "the bench did not finish";
    ASSERT_EQ(*status, 0) << bench.err();
    std::set<std::pair<std::string, int>> rows;
    for (const auto& row : json_lines(bench.out())) {
        rows.insert({row.at("link").get<std::string>(), row.at("size").get<int>()});
        for (const char* key : {"direct_p50_us", "bridged_p50_us", "direct_msgs_per_s", "bridged_msgs_per_s"})
            EXPECT_GT(row.at(key).get<double>(), 0) << key << " in " << row.dump();
        EXPECT_TRUE(row.at("complete").get<bool>())
            << "a round trip was lost or a stream stalled: " << row.dump();
    }
    EXPECT_EQ(rows, (std::set<std::pair<std::string, int>>{
                        {"dds", 64}, {"dds", 65536}, {"mqtt", 64}, {"mqtt", 65536}}));
}

}  // namespace bench_bridges_test
}  // namespace plexus::test
