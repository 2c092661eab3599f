// Monitor scripts written in YARP's style (require("yarp") first, PortMonitor.setConstraint in
// create, a selector connection whose constraint is `false` toggling events) arbitrate an input
// port as YARP's arbitration example describes: the view shows one camera at a time, the one the
// selector's last message picked, and never the selector's own data.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "harness.hpp"

namespace plexus::test {
namespace yarp_style_test {

using nlohmann::json;

std::string yarp_scripts_dir() {
    return (std::filesystem::path(monitors_dir()) / ".." / ".." / "tests" / "integration" / "yarp_scripts")
        .lexically_normal()
        .string();
}

json events_of(const TempDir& dir, const Daemon& daemon, const std::string& port) {
    auto result = run_cli(dir, daemon, {"events", port, "--json"});
    EXPECT_EQ(result.status, 0) << result.err;
    return json::parse(result.out.empty() ? "{}" : result.out);
}

bool has_event(const json& events, const std::string& name) {
    for (const auto& e : events.value("events", json::array())) {
        if (e["name"] == name)
            return true;
    }
    return false;
}

/// How many messages the monitors of the connection into `port` from `source` have judged.
/// Not `received`: that counts a message on arrival, before the monitor's worker has run it.
std::uint64_t judged(const TempDir& dir, const Daemon& daemon, const std::string& port,
                     const std::string& source) {
    const auto events = events_of(dir, daemon, port);
    for (const auto& c : events.value("connections", json::array())) {
        if (c["source"] == source) {
            const auto& counters = c["counters"];
            return counters["accepted"].get<std::uint64_t>() +
                   counters["dropped_by_accept"].get<std::uint64_t>();
        }
    }
    return 0;
}

/// Sends `line` and waits until the daemon has taken it on that connection (its monitor ran).
void send(const TempDir& dir, const Daemon& daemon, CliWriter& writer, const std::string& source,
          const std::string& line) {
    const auto before = judged(dir, daemon, "/view/in", source);
    writer.send(line + "\n");
    ASSERT_TRUE(eventually([&] { return judged(dir, daemon, "/view/in", source) > before; })) << line;
}

/// The selection after a selector message: `chosen` is set and `other` is not.
void expect_selected(const TempDir& dir, const Daemon& daemon, const std::string& chosen,
                     const std::string& other) {
    ASSERT_TRUE(eventually([&] {
        const auto events = events_of(dir, daemon, "/view/in");
        return has_event(events, chosen) && !has_event(events, other);
    })) << events_of(dir, daemon, "/view/in").dump();
}

/// Runs YARP's arbitration scenario with the three carriers given and checks what the view shows.
void arbitrate(const std::vector<std::string>& scripts, const std::string& ball_carrier,
               const std::string& line_carrier, const std::string& selector_carrier, const std::string& ball,
               const std::string& line) {
    TempDir dir;
    std::vector<std::string> flags;
    for (const auto& s : scripts) {
        flags.push_back("--scripts");
        flags.push_back(s);
    }
    Daemon daemon(dir, "robot", "", flags);
    auto view = start_cli(dir, daemon, {"read", "/view/in", "--timeout", "60"}, "view");
    ASSERT_TRUE(wait_port(dir, daemon, "/view/in"));
    CliWriter ball_camera(dir, daemon, "/ball/out", "ball");
    CliWriter line_camera(dir, daemon, "/line/out", "line");
    CliWriter selector(dir, daemon, "/selector/out", "selector");
    for (const auto* port : {"/ball/out", "/line/out", "/selector/out"})
        ASSERT_TRUE(wait_port(dir, daemon, port));
    for (const auto& [source, carrier] : std::vector<std::pair<std::string, std::string>>{
             {"/ball/out", ball_carrier}, {"/line/out", line_carrier}, {"/selector/out", selector_carrier}}) {
        auto connected = run_cli(dir, daemon, {"connect", source, "/view/in", carrier});
        ASSERT_EQ(connected.status, 0) << carrier << ": " << connected.err << daemon.process().err();
    }

    send(dir, daemon, ball_camera, "/ball/out", R"({"n":1})");     // nothing selected yet: dropped
    send(dir, daemon, selector, "/selector/out", R"({"n":100})");  // selects the line
    expect_selected(dir, daemon, line, ball);
    send(dir, daemon, ball_camera, "/ball/out", R"({"n":2})");     // dropped
    send(dir, daemon, line_camera, "/line/out", R"({"n":3})");     // shown
    send(dir, daemon, selector, "/selector/out", R"({"n":101})");  // selects the ball
    expect_selected(dir, daemon, ball, line);
    send(dir, daemon, line_camera, "/line/out", R"({"n":4})");     // dropped
    send(dir, daemon, ball_camera, "/ball/out", R"({"n":5})");     // shown
    send(dir, daemon, selector, "/selector/out", R"({"n":102})");  // the line again
    expect_selected(dir, daemon, line, ball);
    send(dir, daemon, line_camera, "/line/out", R"({"n":6})");  // shown

    ASSERT_TRUE(eventually([&] { return view->out().find(R"({"n":6})") != std::string::npos; }))
        << view->out();
    EXPECT_EQ(view->out(), "{\"n\":3}\n{\"n\":5}\n{\"n\":6}\n");
}

TEST(YarpStyle_test, ScriptsThatBeginWithRequireYarpArbitrateAsInYarpsExample) {
    arbitrate({yarp_scripts_dir()}, "tcp+recv.portmonitor+type.lua+file.ball_view",
              "tcp+recv.portmonitor+type.lua+file.line_view", "tcp+recv.portmonitor+type.lua+file.selector",
              "e_ball_selected", "e_line_selected");
}

TEST(YarpStyle_test, TheExampleSelectorInConfigsTakesTurnsOverTheEventsItIsGiven) {
    arbitrate({monitors_dir()}, "tcp+recv.portmonitor+constraint.e_ball",
              "tcp+recv.portmonitor+constraint.e_line",
              "tcp+recv.portmonitor+type.lua+file.yarp_selector+events.e_line,e_ball", "e_ball", "e_line");
}

TEST(YarpStyle_test, RequireOfAnythingButYarpRefusesTheConnect) {
    TempDir dir;
    const std::string scripts = dir.file("scripts");
    std::filesystem::create_directories(scripts);
    std::ofstream(scripts + "/wants_os.lua") << "require(\"os\")\n";
    Daemon daemon(dir, "robot", "", {"--scripts", scripts});
    auto view = start_cli(dir, daemon, {"read", "/view/in", "--timeout", "30"}, "view");
    CliWriter writer(dir, daemon, "/a/out", "a");
    ASSERT_TRUE(wait_port(dir, daemon, "/view/in") && wait_port(dir, daemon, "/a/out"));
    auto refused = run_cli(dir, daemon,
                           {"connect", "/a/out", "/view/in", "tcp+recv.portmonitor+type.lua+file.wants_os"});
    EXPECT_EQ(refused.status, 4) << refused.err;
    EXPECT_NE(refused.err.find("only require(\"yarp\")"), std::string::npos) << refused.err;
}

}  // namespace yarp_style_test
}  // namespace plexus::test
