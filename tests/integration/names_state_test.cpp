// The name server's state file after a power cut: empty or cut short, it is reported and the name
// server serves all the same, and writes a whole file again at the next change.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "harness.hpp"

namespace plexus::test {
namespace names_state_test {

struct Damage {
    std::string name;
    std::string text;
    std::string reported;  // what the log line says
};

class NamesState_test : public ::testing::TestWithParam<Damage> {};

TEST_P(NamesState_test, ADamagedStateFileIsReportedAndDoesNotStopTheNameServer) {
    TempDir dir;
    const std::string state = dir.file("names.json");
    std::ofstream(state, std::ios::trunc) << GetParam().text;
    const std::string ready = dir.file("names.ready");
    Process names({names_path(), "--listen", "127.0.0.1:0", "--state", state, "--ready-file", ready}, {},
                  dir.file("names"));
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(ready) || !names.running(); }));
    ASSERT_TRUE(names.running()) << names.err();
    const std::string log = names.out() + names.err();
    EXPECT_NE(log.find("state file " + state + " " + GetParam().reported), std::string::npos) << log;

    // It serves: a daemon registers, a persistent connection is made, and the state file is
    // whole JSON again, with that connection in it.
    const std::string where = nlohmann::json::parse(read_file(ready))["names"];
    Daemon daemon(dir, "solo", where);
    auto sink = start_cli(dir, daemon, {"read", "/sink", "--timeout", "30"}, "sink");
    auto source = start_cli(dir, daemon, {"read", "/src", "--timeout", "30"}, "src");
    ASSERT_TRUE(wait_port(dir, daemon, "/sink") && wait_port(dir, daemon, "/src"));
    ASSERT_EQ(run_cli(dir, daemon, {"connect", "/src", "/sink", "--persist"}).status, 0);
    ASSERT_TRUE(eventually([&] {
        const auto saved = nlohmann::json::parse(read_file(state), nullptr, false);
        return !saved.is_discarded() && saved.contains("persistent") && saved["persistent"].size() == 1 &&
               saved["persistent"][0]["source"] == "/src";
    })) << read_file(state);
    EXPECT_FALSE(std::filesystem::exists(state + ".tmp"));
}

INSTANTIATE_TEST_SUITE_P(Damages, NamesState_test,
                         ::testing::Values(Damage{"Empty", "", "is empty"},
                                           Damage{"CutShort", R"({"persistent": [{"source": "/a", "destin)",
                                                  "is not valid JSON"},
                                           Damage{"Garbage", "\x01\x02 not json", "is not valid JSON"}),
                         [](const ::testing::TestParamInfo<Damage>& info) { return info.param.name; });

}  // namespace names_state_test
}  // namespace plexus::test
