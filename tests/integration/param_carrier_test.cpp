// `plexus param set` changes what a monitor runs with, so the carrier text that describes the
// connection -- in `stats` at both ends and in the name server's `list` -- says the new values:
// in the clause of the monitor that took them, added when the clause lacked the key.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>

#include "harness.hpp"

namespace plexus::test {
namespace param_carrier_test {

using nlohmann::json;

void write_script(const TempDir& dir, const std::string& name, const std::string& code) {
    std::ofstream(dir.file("scripts/" + name + ".lua")) << code;
}

/// Keeps whatever it is given, and gives it back.
const char* const tunable = R"(
local params = {}
PortMonitor.create = function(options)
    params.threshold = options.threshold
    return true
end
PortMonitor.setparam = function(t) for k, v in pairs(t) do params[k] = v end end
PortMonitor.getparam = function() return params end
)";

/// No setparam: a param set leaves its clause as it was.
const char* const fixed = "PortMonitor.getparam = function() return {} end\n";

std::string listed_carrier(const TempDir& dir, const Daemon& daemon, const std::string& source,
                           const std::string& destination) {
    auto list = run_cli(dir, daemon, {"list", "--json"});
    EXPECT_EQ(list.status, 0) << list.err;
    const auto live = json::parse(list.out);
    for (const auto& c : live["connections"]) {
        if (c["source"] == source && c["destination"] == destination)
            return c["carrier"].get<std::string>();
    }
    return "";
}

struct Setup {
    std::string base;  ///< the base carrier
    bool two_daemons;  ///< the sink on a second daemon: its end of the carrier is rewritten there
};

class ParamCarrier_test : public ::testing::TestWithParam<Setup> {};

TEST_P(ParamCarrier_test, ParamSetShowsTheNewValuesInTheCarrier) {
    const std::string base = GetParam().base;
    TempDir dir;
    std::filesystem::create_directories(dir.file("scripts"));
    write_script(dir, "tunable", tunable);
    write_script(dir, "fixed", fixed);
    Daemon daemon(dir, "first", "", {"--scripts", dir.file("scripts")});
    std::unique_ptr<Daemon> second;
    if (GetParam().two_daemons)
        second = std::make_unique<Daemon>(dir, "second", daemon.names(),
                                          std::vector<std::string>{"--scripts", dir.file("scripts")});
    const Daemon& sink_side = second ? *second : daemon;
    auto reader = start_cli(dir, sink_side, {"read", "/sink", "--timeout", "60"}, "sink");
    ASSERT_TRUE(wait_port(dir, daemon, "/sink"));
    CliWriter writer(dir, daemon, "/source", "writer");
    ASSERT_TRUE(wait_port(dir, daemon, "/source"));
    const std::string carrier = base +
                                "+send.portmonitor+type.lua+file.fixed+gain.1"
                                "+recv.portmonitor+type.lua+file.tunable+threshold.0.8";
    auto connected = run_cli(dir, daemon, {"connect", "/source", "/sink", carrier});
    ASSERT_EQ(connected.status, 0) << connected.err;
    ASSERT_EQ(outgoing_stats(dir, daemon, "/source", "/sink")["carrier"], carrier);

    auto set = run_cli(dir, daemon, {"param", "set", "/source", "/sink", "threshold=0.95", "mode=fast"});
    ASSERT_EQ(set.status, 0) << set.err;

    // threshold changed in place, mode added to the clause that took it; the send clause is as it was.
    const std::string expected = base +
                                 "+send.portmonitor+type.lua+file.fixed+gain.1"
                                 "+recv.portmonitor+type.lua+file.tunable+threshold.0.95+mode.fast";
    EXPECT_EQ(outgoing_stats(dir, daemon, "/source", "/sink")["carrier"], expected);
    EXPECT_EQ(inbound_stats(dir, sink_side, "/sink", "/source")["carrier"], expected);
    EXPECT_TRUE(eventually([&] { return listed_carrier(dir, daemon, "/source", "/sink") == expected; }))
        << listed_carrier(dir, daemon, "/source", "/sink");

    // A value the carrier grammar cannot hold ('+' separates parts) reaches the monitor, but the
    // carrier is not corrupted by it: that key keeps its old text.
    auto plus = run_cli(dir, daemon, {"param", "set", "/source", "/sink", "mode=a+b"});
    ASSERT_EQ(plus.status, 0) << plus.err;
    EXPECT_EQ(json::parse(plus.out)[1]["param"]["mode"], "a+b");
    EXPECT_EQ(outgoing_stats(dir, daemon, "/source", "/sink")["carrier"], expected);
}

INSTANTIATE_TEST_SUITE_P(LocalThroughALinkAndAcrossDaemons, ParamCarrier_test,
                         ::testing::Values(Setup{"local", false}, Setup{"tcp", false}, Setup{"tcp", true}),
                         [](const ::testing::TestParamInfo<Setup>& info) {
                             return info.param.base +
                                    (info.param.two_daemons ? "_two_daemons" : "_one_daemon");
                         });

}  // namespace param_carrier_test
}  // namespace plexus::test
