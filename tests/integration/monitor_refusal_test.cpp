// A monitor's create that refuses: `plexus connect` fails (exit 4) and says why, in the script's
// own words -- what it raised, the reason it returned beside false, or the last line it printed --
// on either side of the connection, and never more than a bounded amount of it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "harness.hpp"

namespace plexus::test {
namespace monitor_refusal_test {

void write_script(const TempDir& dir, const std::string& name, const std::string& code) {
    std::ofstream(dir.file("scripts/" + name + ".lua")) << code;
}

TEST(MonitorRefusal_test, ConnectSaysWhyCreateRefused) {
    TempDir dir;
    std::filesystem::create_directories(dir.file("scripts"));
    write_script(dir, "second_result", "PortMonitor.create = function(o) return false, 'no camera' end\n");
    write_script(dir, "printed",
                 "PortMonitor.create = function(o)\n"
                 "  print('checking the lens')\n"
                 "  print('lens cap on')\n"
                 "  return false\n"
                 "end\n");
    write_script(dir, "raises", "PortMonitor.create = function(o) error('camera not calibrated') end\n");
    // A reason given beside false wins over what was printed.
    write_script(dir, "both",
                 "PortMonitor.create = function(o) print('noise') return false, 'the reason' end\n");
    write_script(dir, "long",
                 "PortMonitor.create = function(o) return false, 'why' .. string.rep('x', 100000) end\n");
    Daemon daemon(dir, "solo", "", {"--scripts", dir.file("scripts")});
    auto reader = start_cli(dir, daemon, {"read", "/sink", "--timeout", "60"}, "sink");
    ASSERT_TRUE(wait_port(dir, daemon, "/sink"));
    CliWriter writer(dir, daemon, "/source", "writer");
    ASSERT_TRUE(wait_port(dir, daemon, "/source"));

    struct Case {
        std::string script;
        std::string reason;
    };
    const std::vector<Case> cases{{"second_result", "no camera"},
                                  {"printed", "lens cap on"},
                                  {"raises", "camera not calibrated"},
                                  {"both", "the reason"}};
    // local: the recv side made in this daemon; tcp: through a link (here to the same daemon),
    // the recv side made at the far end and its refusal carried back.
    for (const std::string clause : {"local+recv", "tcp+recv", "tcp+send"}) {
        for (const auto& c : cases) {
            const std::string carrier = clause + ".portmonitor+type.lua+file." + c.script;
            auto result = run_cli(dir, daemon, {"connect", "/source", "/sink", carrier});
            EXPECT_EQ(result.status, 4) << carrier << ": " << result.err;
            EXPECT_NE(result.err.find(c.reason), std::string::npos) << carrier << ": " << result.err;
            EXPECT_EQ(run_cli(dir, daemon, {"exists", "/source", "/sink"}).status, 1) << carrier;
        }
    }
    EXPECT_EQ(run_cli(dir, daemon, {"connect", "/source", "/sink", "local+recv.portmonitor+file.both"})
                  .err.find("noise"),
              std::string::npos);

    // A huge reason is cut: the refusal stays one readable line, not 100 kB.
    auto long_reason =
        run_cli(dir, daemon, {"connect", "/source", "/sink", "local+recv.portmonitor+type.lua+file.long"});
    EXPECT_EQ(long_reason.status, 4);
    EXPECT_NE(long_reason.err.find("whyxxx"), std::string::npos) << long_reason.err;
    EXPECT_LT(long_reason.err.size(), 1000u) << long_reason.err.size();
}

TEST(MonitorRefusal_test, ShippedExampleExplainsAMissingCondition) {
    // The `when` example prints what it needs before it refuses: the user sees it at connect.
    TempDir dir;
    Daemon daemon(dir, "solo", "", {"--scripts", monitors_dir()});
    auto reader = start_cli(dir, daemon, {"read", "/held", "--timeout", "60"}, "held");
    ASSERT_TRUE(wait_port(dir, daemon, "/held"));
    CliWriter writer(dir, daemon, "/touch", "writer");
    ASSERT_TRUE(wait_port(dir, daemon, "/touch"));
    auto refused = run_cli(
        dir, daemon, {"connect", "/touch", "/held", "local+recv.portmonitor+type.lua+file.when+field.held"});
    EXPECT_EQ(refused.status, 4);
    EXPECT_NE(refused.err.find("give equals.VALUE, below.X or above.X"), std::string::npos) << refused.err;
}

}  // namespace monitor_refusal_test
}  // namespace plexus::test
