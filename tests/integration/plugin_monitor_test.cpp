// Compiled monitors end to end (issue 19, item 2): plexusd --monitor-libs, `plexus connect` with
// type.so, `plexus read`, `plexus events`, `plexus stats`. The certainty plugin and certainty.lua
// get the same inputs from one writer and must give the same deliveries and events; a plugin
// with the wrong ABI version and one outside --monitor-libs are refused (exit 4, the reason); a
// plugin that throws is contained, counted and quarantined while the daemon goes on.
#include <gtest/gtest.h>

#include "harness.hpp"

namespace plexus::test {
namespace plugin_monitor_test {

using nlohmann::json;

const std::string test_plugins = PLEXUS_TEST_PLUGINS_DIR;
const std::string example_plugins = PLEXUS_EXAMPLE_PLUGINS_DIR;

json events_of(const TempDir& dir, const Daemon& daemon, const std::string& port) {
    auto result = run_cli(dir, daemon, {"events", port, "--json"});
    EXPECT_EQ(result.status, 0) << result.err;
    return result.out.empty() ? json() : json::parse(result.out);
}

json connection_of(const json& events, const std::string& source) {
    for (const auto& c : events["connections"]) {
        if (c["source"] == source)
            return c;
    }
    return nullptr;
}

/// Messages the monitors of the connection have given a verdict on.
std::uint64_t judged(const json& connection) {
    if (connection.is_null())
        return 0;
    return connection["counters"]["accepted"].get<std::uint64_t>() +
           connection["counters"]["dropped_by_accept"].get<std::uint64_t>();
}

/// The event container as names and owners, which both monitors must leave alike.
json container_of(const json& events) {
    auto list = json::array();
    for (const auto& event : events["events"])
        list.push_back({event["name"], event["owner"]});
    return list;
}

TEST(PluginMonitor_test, CertaintyPluginAndCertaintyLuaGiveTheSameDeliveriesAndEvents) {
    TempDir dir;
    Daemon daemon(dir, "robot", "", {"--scripts", monitors_dir(), "--monitor-libs", example_plugins});
    auto lua_reader = start_cli(dir, daemon, {"read", "/lua/in"}, "lua-reader");
    auto so_reader = start_cli(dir, daemon, {"read", "/so/in"}, "so-reader");
    ASSERT_TRUE(wait_port(dir, daemon, "/lua/in"));
    ASSERT_TRUE(wait_port(dir, daemon, "/so/in"));
    CliWriter writer(dir, daemon, "/det/out", "detector");
    ASSERT_TRUE(wait_port(dir, daemon, "/det/out"));
    const std::string options = "+threshold.0.7+event.e_ok";
    for (const auto& [port, type] : {std::pair{"/lua/in", "lua"}, std::pair{"/so/in", "so"}}) {
        auto connected =
            run_cli(dir, daemon,
                    {"connect", "/det/out", port,
                     std::string("tcp+recv.portmonitor+type.") + type + "+file.certainty" + options});
        ASSERT_EQ(connected.status, 0) << type << ": " << connected.err;
    }

    // Good, bad, and payloads the script's type checks tell apart; one at a time, so that the
    // event container can be compared after each.
    const std::vector<std::string> inputs{
        R"({"n":1,"certainty":0.9})",
        R"({"n":2,"certainty":0.3})",
        R"({"n":3,"certainty":0.7})",
        R"({"n":4,"certainty":"0.9"})",
        R"({"n":5})",
        R"([0.9])",
        R"({"n":7,"certainty":1})",
        R"("certainty")",
        R"({"n":9,"certainty":0.69})",
        R"({"n":10,"certainty":0.99})",
    };
    bool raised = false;
    bool cleared = false;
    for (std::size_t i = 0; i < inputs.size(); ++i) {
        writer.send(inputs[i] + "\n");
        json lua_events;
        json so_events;
        ASSERT_TRUE(eventually([&] {
            lua_events = events_of(dir, daemon, "/lua/in");
            so_events = events_of(dir, daemon, "/so/in");
            return judged(connection_of(lua_events, "/det/out")) == i + 1 &&
                   judged(connection_of(so_events, "/det/out")) == i + 1;
        })) << "the monitors never judged "
            << inputs[i];
        EXPECT_EQ(container_of(so_events), container_of(lua_events)) << "after " << inputs[i];
        EXPECT_EQ(connection_of(so_events, "/det/out")["counters"],
                  connection_of(lua_events, "/det/out")["counters"])
            << "after " << inputs[i];
        raised = raised || !lua_events["events"].empty();
        cleared = cleared || lua_events["events"].empty();
    }
    EXPECT_TRUE(raised && cleared) << "the inputs must both raise and clear the event";

    // n 1, 3 and 7 and 10 reach the threshold.
    std::vector<json> lua_lines;
    std::vector<json> so_lines;
    ASSERT_TRUE(eventually([&] {
        lua_lines = json_lines(lua_reader->out());
        so_lines = json_lines(so_reader->out());
        return lua_lines.size() >= 4 && so_lines.size() >= 4;
    })) << lua_reader->out()
        << " / " << so_reader->out();
    EXPECT_EQ(so_lines, lua_lines);
    ASSERT_EQ(lua_lines.size(), 4u);
    EXPECT_EQ(lua_lines[3]["n"], 10);

    // The same parameters through `plexus param`, and a change made there acts alike.
    auto lua_param = run_cli(dir, daemon, {"param", "get", "/det/out", "/lua/in"});
    auto so_param = run_cli(dir, daemon, {"param", "get", "/det/out", "/so/in"});
    ASSERT_EQ(so_param.status, 0) << so_param.err;
    EXPECT_EQ(so_param.out, lua_param.out);
    EXPECT_EQ(run_cli(dir, daemon, {"param", "set", "/det/out", "/so/in", "threshold=0.95"}).status, 0);
    EXPECT_EQ(run_cli(dir, daemon, {"param", "set", "/det/out", "/lua/in", "threshold=0.95"}).status, 0);
    writer.send(R"({"n":11,"certainty":0.9})"
                "\n"
                R"({"n":12,"certainty":0.96})"
                "\n");
    ASSERT_TRUE(eventually([&] {
        return json_lines(lua_reader->out()).size() >= 5 && json_lines(so_reader->out()).size() >= 5;
    }));
    EXPECT_EQ(json_lines(so_reader->out()), json_lines(lua_reader->out()));
    EXPECT_EQ(json_lines(so_reader->out()).back()["n"], 12);
    EXPECT_EQ(writer.finish(), 0);
}

TEST(PluginMonitor_test, WrongAbiAndPluginsOutsideMonitorLibsAreRefusedWithTheReason) {
    TempDir dir;
    // The example plugins' directory is given as a --scripts directory only: not a place plugins load from.
    Daemon daemon(dir, "robot", "", {"--monitor-libs", test_plugins, "--scripts", example_plugins});
    auto reader = start_cli(dir, daemon, {"read", "/in"}, "reader");
    CliWriter writer(dir, daemon, "/out", "writer");
    ASSERT_TRUE(wait_port(dir, daemon, "/in"));
    ASSERT_TRUE(wait_port(dir, daemon, "/out"));
    auto connect = [&](const std::string& file) {
        return run_cli(dir, daemon, {"connect", "/out", "/in", "tcp+recv.portmonitor+type.so+file." + file});
    };

    auto wrong_abi = connect("wrong_abi");
    EXPECT_EQ(wrong_abi.status, 4);
    EXPECT_NE(wrong_abi.err.find("built for monitor ABI version 999, this plexusd speaks version 1"),
              std::string::npos)
        << wrong_abi.err;
    auto no_entry = connect("no_entry");
    EXPECT_EQ(no_entry.status, 4);
    EXPECT_NE(no_entry.err.find("has no plexus_monitor_entry symbol"), std::string::npos) << no_entry.err;
    auto outside = connect("certainty");
    EXPECT_EQ(outside.status, 4);
    EXPECT_NE(outside.err.find("not found in the --monitor-libs directories"), std::string::npos)
        << outside.err;
    auto absolute = connect(example_plugins + "/certainty");
    EXPECT_EQ(absolute.status, 4);
    EXPECT_NE(absolute.err.find("must be relative"), std::string::npos) << absolute.err;
    auto unknown_type =
        run_cli(dir, daemon, {"connect", "/out", "/in", "tcp+recv.portmonitor+type.dll+file.x"});
    EXPECT_EQ(unknown_type.status, 4);
    EXPECT_NE(unknown_type.err.find("type.lua or type.so"), std::string::npos) << unknown_type.err;
    EXPECT_EQ(run_cli(dir, daemon, {"exists", "/out", "/in"}).status, 1)
        << "a refused connect left a connection";
}

TEST(PluginMonitor_test, ThrowingPluginIsContainedCountedAndTheDaemonGoesOn) {
    TempDir dir;
    Daemon daemon(dir, "robot", "", {"--monitor-libs", test_plugins});
    auto thrown_reader = start_cli(dir, daemon, {"read", "/thrown/in"}, "thrown-reader");
    auto plain_reader = start_cli(dir, daemon, {"read", "/plain/in", "--count", "5"}, "plain-reader");
    ASSERT_TRUE(wait_port(dir, daemon, "/thrown/in"));
    ASSERT_TRUE(wait_port(dir, daemon, "/plain/in"));
    CliWriter writer(dir, daemon, "/out", "writer");
    ASSERT_TRUE(wait_port(dir, daemon, "/out"));
    auto connected =
        run_cli(dir, daemon, {"connect", "/out", "/thrown/in", "tcp+recv.portmonitor+type.so+file.throwing"});
    ASSERT_EQ(connected.status, 0) << connected.err;
    ASSERT_EQ(run_cli(dir, daemon, {"connect", "/out", "/plain/in"}).status, 0);
    writer.send(numbered_lines(1, 5));
    ASSERT_EQ(plain_reader->wait(), 0) << "the unmonitored connection stopped delivering";
    EXPECT_EQ(json_lines(plain_reader->out()).size(), 5u);

    json monitor;
    ASSERT_TRUE(eventually([&] {
        monitor = inbound_stats(dir, daemon, "/thrown/in", "/out")["monitors"][0];
        return monitor.is_object() && monitor["errors"] == 5;
    })) << monitor.dump();
    EXPECT_EQ(monitor["type"], "so");
    EXPECT_EQ(monitor["dropped"], 5);
    EXPECT_NE(monitor["last_error"].get<std::string>().find("accept threw plugin exploded on message 5"),
              std::string::npos)
        << monitor.dump();
    EXPECT_EQ(monitor["quarantined"], true) << "5 failures in a row quarantine a monitor (the default)";
    EXPECT_TRUE(json_lines(thrown_reader->out()).empty()) << thrown_reader->out();
    EXPECT_TRUE(daemon.process().running());
    EXPECT_EQ(writer.finish(), 0);
}

}  // namespace plugin_monitor_test
}  // namespace plexus::test
