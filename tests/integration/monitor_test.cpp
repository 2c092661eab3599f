// Port monitors end to end through the CLI: the example monitors of configs/monitors on one
// daemon and across two, on the send and recv sides; failures at connect time; hostile scripts
// that must not hurt the daemon or the other connections.
#include <gtest/gtest.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "harness.hpp"

namespace plexus::test {
namespace monitor_test {

using nlohmann::json;

std::vector<std::string> with_scripts(const std::string& extra_dir = "") {
    std::vector<std::string> args{"--scripts", monitors_dir()};
    if (!extra_dir.empty()) {
        args.push_back("--scripts");
        args.push_back(extra_dir);
    }
    return args;
}

json stats_of(const TempDir& dir, const Daemon& daemon, const std::string& port) {
    auto result = run_cli(dir, daemon, {"stats", port, "--json"});
    EXPECT_EQ(result.status, 0) << result.err;
    return json::parse(result.out);
}

/// Whether the recv monitors of `port`'s first inbound connection have judged `count` messages.
/// "received" alone is not enough: it counts a message on arrival, before the monitor's worker runs.
bool judged(const TempDir& dir, const Daemon& daemon, const std::string& port, int count) {
    auto inbound = stats_of(dir, daemon, port)["ports"][0]["inbound"][0];
    return inbound["accepted"].get<int>() + inbound["dropped_by_accept"].get<int>() == count;
}

/// A reader on `sink`, a writer on `source`, connected with `carrier` from the writer's daemon.
struct Pipeline {
    std::unique_ptr<Process> reader;
    std::unique_ptr<CliWriter> writer;
    CliResult connected;
};

Pipeline make_pipeline(const TempDir& dir, const Daemon& write_side, const Daemon& read_side,
                       const std::string& source, const std::string& sink, const std::string& carrier,
                       int count, const std::string& name = "p") {
    Pipeline p;
    p.reader = start_cli(dir, read_side, {"read", sink, "--count", std::to_string(count), "--timeout", "60"},
                         name + "-reader");
    EXPECT_TRUE(wait_port(dir, write_side, sink));
    p.writer = std::make_unique<CliWriter>(dir, write_side, source, name + "-writer");
    EXPECT_TRUE(wait_port(dir, write_side, source));
    p.connected = run_cli(dir, write_side, {"connect", source, sink, carrier});
    return p;
}

TEST(Monitor_test, CertaintyFilterOnTheRecvSideWithParamGetAndSet) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", with_scripts());
    auto p = make_pipeline(dir, daemon, daemon, "/detector", "/consumer",
                           "tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.8", 3);
    ASSERT_EQ(p.connected.status, 0) << p.connected.err;

    auto got = run_cli(dir, daemon, {"param", "get", "/detector", "/consumer"});
    ASSERT_EQ(got.status, 0) << got.err;
    EXPECT_EQ(json::parse(got.out),
              json::parse(R"([{"script":"certainty","side":"recv","param":{"threshold":0.8}}])"));
    p.writer->send(
        "{\"c\":1,\"certainty\":0.9}\n{\"c\":2,\"certainty\":0.5}\n{\"c\":3,\"certainty\":0.81}\n");
    // Raise the threshold only once those three have been judged: the stats say so.
    ASSERT_TRUE(eventually([&] { return judged(dir, daemon, "/consumer", 3); }));
    auto set = run_cli(dir, daemon, {"param", "set", "/detector", "/consumer", "threshold=0.95"});
    ASSERT_EQ(set.status, 0) << set.err;
    EXPECT_EQ(json::parse(set.out)[0]["param"]["threshold"], 0.95);
    p.writer->send("{\"c\":4,\"certainty\":0.9}\n");
    ASSERT_TRUE(eventually([&] { return judged(dir, daemon, "/consumer", 4); }));
    auto inbound = stats_of(dir, daemon, "/consumer")["ports"][0]["inbound"][0];
    EXPECT_EQ(inbound["dropped_by_accept"], 2);
    EXPECT_EQ(inbound["monitors"][0]["dropped"], 2);
    p.writer->send("{\"c\":5,\"certainty\":0.99}\n");
    ASSERT_EQ(p.writer->finish(), 0);
    ASSERT_EQ(p.reader->wait(60s), 0) << p.reader->err();
    auto lines = json_lines(p.reader->out());
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_EQ(lines[0]["c"], 1);
    EXPECT_EQ(lines[1]["c"], 3);
    EXPECT_EQ(lines[2]["c"], 5);
}

TEST(Monitor_test, WorkspaceGuardOnTheSendSideAcrossTwoDaemons) {
    TempDir dir;
    Daemon first(dir, "first", "", with_scripts());
    Daemon second(dir, "second", first.names(), with_scripts());
    auto p = make_pipeline(
        dir, first, second, "/arm/target", "/arm/controller",
        "tcp+send.portmonitor+type.lua+file.workspace+xmin.-0.5+xmax.0.5+ymin.-0.5+ymax.0.5+zmin.0+zmax.1",
        2);
    ASSERT_EQ(p.connected.status, 0) << p.connected.err;
    p.writer->send(
        "{\"x\":0.1,\"y\":0.2,\"z\":0.5}\n{\"x\":0.9,\"y\":0.0,\"z\":0.5}\n"
        "{\"x\":0.0,\"y\":0.0,\"z\":-0.1}\n{\"x\":-0.5,\"y\":0.5,\"z\":1}\n");
    ASSERT_EQ(p.writer->finish(), 0);
    ASSERT_EQ(p.reader->wait(60s), 0) << p.reader->err();
    auto lines = json_lines(p.reader->out());
    ASSERT_EQ(lines.size(), 2u);
    EXPECT_EQ(lines[0], json::parse(R"({"x":0.1,"y":0.2,"z":0.5})"));
    EXPECT_EQ(lines[1], json::parse(R"({"x":-0.5,"y":0.5,"z":1})"));
}

TEST(Monitor_test, CodecPairEncodesOnSendAndDecodesOnRecvAcrossTwoDaemons) {
    TempDir dir;
    Daemon first(dir, "first", "", with_scripts());
    Daemon second(dir, "second", first.names(), with_scripts());
    auto p =
        make_pipeline(dir, first, second, "/laser/scan", "/mapper/scan",
                      "tcp+send.portmonitor+type.lua+file.codec+recv.portmonitor+type.lua+file.codec", 4);
    ASSERT_EQ(p.connected.status, 0) << p.connected.err;
    // Values exact in 32-bit floats come back exactly; a non-array passes untouched.
    p.writer->send("[1.5,2.25,-3.0,1024.0]\n{\"not\":\"a scan\"}\n[0.5]\n");
    ASSERT_TRUE(eventually([&] { return judged(dir, second, "/mapper/scan", 3); }));
    auto sent = stats_of(dir, first, "/laser/scan")["ports"][0]["outgoing"][0]["monitors"][0];
    EXPECT_EQ(sent["side"], "send");
    EXPECT_EQ(sent["rewritten"], 2);
    auto received = stats_of(dir, second, "/mapper/scan")["ports"][0]["inbound"][0]["monitors"][0];
    EXPECT_EQ(received["side"], "recv");
    EXPECT_EQ(received["rewritten"], 2);
    p.writer->send("\"end\"\n");
    ASSERT_EQ(p.writer->finish(), 0);
    ASSERT_EQ(p.reader->wait(60s), 0) << p.reader->err();
    auto lines = json_lines(p.reader->out());
    ASSERT_EQ(lines.size(), 4u);
    EXPECT_EQ(lines[0], json::parse("[1.5,2.25,-3.0,1024.0]"));
    EXPECT_EQ(lines[1], json::parse(R"({"not":"a scan"})"));
    EXPECT_EQ(lines[2], json::parse("[0.5]"));
}

TEST(Monitor_test, FormatConverterReshapesMessagesOnALocalConnection) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", with_scripts());
    auto p = make_pipeline(dir, daemon, daemon, "/face/out", "/gaze/in",
                           "local+recv.portmonitor+type.lua+file.convert+frame.left_eye", 2);
    ASSERT_EQ(p.connected.status, 0) << p.connected.err;
    p.writer->send("{\"u\":120,\"v\":80,\"certainty\":0.7}\n\"hello\"\n");
    ASSERT_EQ(p.writer->finish(), 0);
    ASSERT_EQ(p.reader->wait(60s), 0) << p.reader->err();
    auto lines = json_lines(p.reader->out());
    ASSERT_EQ(lines.size(), 2u);
    EXPECT_EQ(lines[0], json::parse(R"({"target":[120,80],"frame":"left_eye","weight":0.7})"));
    EXPECT_EQ(lines[1], "hello");
}

/// The names of the events in `port`'s container now.
std::set<std::string> events_of(const TempDir& dir, const Daemon& daemon, const std::string& port) {
    auto result = run_cli(dir, daemon, {"events", port, "--json"});
    std::set<std::string> names;
    if (result.status != 0) {
        ADD_FAILURE() << result.err;
        return names;
    }
    const auto answer = json::parse(result.out);  // named: a range-for over a temporary's member dangles
    for (const auto& event : answer["events"])
        names.insert(event["name"].get<std::string>());
    return names;
}

TEST(Monitor_test, WhenRaisesAnEventWhileAFieldHoldsAndFiltersOnRequest) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", with_scripts());
    // Two clauses in a chain on one connection: each its own condition and event, neither filters.
    auto p =
        make_pipeline(dir, daemon, daemon, "/hand/proximity", "/hand/in",
                      "local+recv.portmonitor+type.lua+file.when+field.object+below.0.03+event.e_at_object"
                      "+recv.portmonitor+type.lua+file.when+field.person+below.0.35+event.e_at_person",
                      5);
    ASSERT_EQ(p.connected.status, 0) << p.connected.err;
    p.writer->send("{\"object\": 0.01, \"person\": 1.0}\n");
    ASSERT_TRUE(eventually(
        [&] { return events_of(dir, daemon, "/hand/in") == std::set<std::string>{"e_at_object"}; }));
    p.writer->send("{\"object\": 0.5, \"person\": 0.2}\n");
    ASSERT_TRUE(eventually(
        [&] { return events_of(dir, daemon, "/hand/in") == std::set<std::string>{"e_at_person"}; }));
    // A missing field (null) does not hold: the event goes.
    p.writer->send("{\"object\": null, \"person\": 0.2}\n{\"object\": null, \"person\": null}\n");
    EXPECT_TRUE(eventually([&] { return events_of(dir, daemon, "/hand/in").empty(); }));
    p.writer->send("{}\n");
    ASSERT_EQ(p.writer->finish(), 0);
    ASSERT_EQ(p.reader->wait(60s), 0) << p.reader->err();
    EXPECT_EQ(json_lines(p.reader->out()).size(), 5u);  // no filter: everything passed

    // With `filter`, only the messages where the condition holds pass.
    auto q = make_pipeline(dir, daemon, daemon, "/touch", "/held",
                           "local+recv.portmonitor+type.lua+file.when+field.held+equals.true+filter", 2, "q");
    ASSERT_EQ(q.connected.status, 0) << q.connected.err;
    // A clause without a condition is refused at connect time, with the script's reason.
    auto other = start_cli(dir, daemon, {"read", "/other", "--timeout", "60"}, "other");
    ASSERT_TRUE(wait_port(dir, daemon, "/other"));
    auto refused = run_cli(
        dir, daemon, {"connect", "/touch", "/other", "local+recv.portmonitor+type.lua+file.when+field.held"});
    EXPECT_EQ(refused.status, 4);
    EXPECT_NE(refused.err.find("script 'when' refused the connection"), std::string::npos) << refused.err;
    EXPECT_TRUE(
        eventually([&] { return daemon.process().out().find("give equals.VALUE") != std::string::npos; }));

    q.writer->send("{\"held\": false}\n{\"held\": true}\n{\"held\": 1}\n\"held\"\n{\"held\": true}\n");
    ASSERT_EQ(q.writer->finish(), 0);
    ASSERT_EQ(q.reader->wait(60s), 0) << q.reader->err();
    EXPECT_EQ(json_lines(q.reader->out()),
              (std::vector<json>{json::parse(R"({"held":true})"), json::parse(R"({"held":true})")}));
}

TEST(Monitor_test, QualityOfServiceMonitorPublishesWhenItsSourceGoesSilent) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", with_scripts());
    auto p = make_pipeline(dir, daemon, daemon, "/camera/out", "/tracker/in",
                           "tcp+recv.portmonitor+type.lua+file.qos+timeout.0.3+port./camera/qos", 2, "qos");
    ASSERT_EQ(p.connected.status, 0) << p.connected.err;
    ASSERT_TRUE(wait_port(dir, daemon, "/camera/qos"));  // made by the monitor's create
    // The watcher must see a silence announced, then the recovery. The first silence starts at
    // create and is announced 0.3 s later, which a slow machine (ASan) may do before the watcher
    // is connected: then a frame (recovery) and a second silence come first. Three events either way.
    auto watcher = start_cli(dir, daemon,
                             {"read", "/watch", "/camera/qos", "--count", "3", "--timeout", "60"}, "watcher");
    ASSERT_TRUE(
        eventually([&] { return !stats_of(dir, daemon, "/camera/qos")["ports"][0]["outgoing"].empty(); }));
    const auto published = [&] {
        return stats_of(dir, daemon, "/camera/qos")["daemon"]["monitor_published"].get<int>();
    };
    const int before = published();  // 1 (create's "ok"), or 2 with the first silence announced
    if (before >= 2) {
        p.writer->send("{\"frame\":1}\n");  // e_qos_ok, then silence again: e_qos_not_ok
        ASSERT_TRUE(eventually([&] { return published() >= before + 2; }));
        p.writer->send("{\"frame\":2}\n");  // e_qos_ok
    } else {
        ASSERT_TRUE(eventually([&] { return published() >= 2; }));  // e_qos_not_ok
        p.writer->send("{\"frame\":1}\n");                          // e_qos_ok, then silence again
        ASSERT_TRUE(eventually([&] { return published() >= 4; }));
        p.writer->send("{\"frame\":2}\n");
    }
    ASSERT_EQ(watcher->wait(60s), 0) << watcher->err();
    auto events = json_lines(watcher->out());
    ASSERT_EQ(events.size(), 3u);
    const std::size_t silence = events[0]["event"] == "e_qos_not_ok" ? 0 : 1;
    EXPECT_EQ(events[silence]["event"], "e_qos_not_ok") << watcher->out();
    EXPECT_GT(events[silence]["silent_for"].get<double>(), 0.3);
    EXPECT_EQ(events[silence + 1]["event"], "e_qos_ok") << watcher->out();
    ASSERT_EQ(p.writer->finish(), 0);
    ASSERT_EQ(p.reader->wait(60s), 0);
    // The camera port closed, its connection went, and the published port went with the monitor.
    EXPECT_TRUE(eventually([&] { return run_cli(dir, daemon, {"exists", "/camera/qos"}).status == 1; }));
}

TEST(Monitor_test, RateLoggerPublishesCountsAndLogs) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", with_scripts());
    auto p = make_pipeline(dir, daemon, daemon, "/imu/out", "/fusion/in",
                           "tcp+recv.portmonitor+type.lua+file.rate_logger+every.0.1+port./imu/rate", 101);
    ASSERT_EQ(p.connected.status, 0) << p.connected.err;
    ASSERT_TRUE(wait_port(dir, daemon, "/imu/rate"));  // after the first report, 0.1 s in
    auto watcher = start_cli(dir, daemon, {"read", "/rates", "/imu/rate", "--timeout", "60"}, "watcher");
    std::string lines;
    for (int i = 0; i < 100; ++i)
        lines += std::to_string(i) + "\n";
    p.writer->send(lines);
    // The monitor (and its port) lives as long as the connection: look before the reader leaves.
    EXPECT_TRUE(eventually([&] {
        return watcher->out().find("\"total_messages\":100") != std::string::npos;
    })) << watcher->out();
    p.writer->send("last\n");
    ASSERT_EQ(p.writer->finish(), 0);
    ASSERT_EQ(p.reader->wait(60s), 0);
    EXPECT_NE((daemon.process().out() + daemon.process().err()).find("100 messages in all"),
              std::string::npos);
}

void write_script(const TempDir& dir, const std::string& name, const std::string& code) {
    std::ofstream(dir.file("scripts/" + name + ".lua")) << code;
}

TEST(Monitor_test, ConnectFailsWithTheScriptErrorAndLeavesNothingBehind) {
    TempDir dir;
    std::filesystem::create_directories(dir.file("scripts"));
    write_script(dir, "broken", "PortMonitor.accept = function(msg)\n  return msg.data >> end\n");
    write_script(dir, "refuses", "PortMonitor.create = function(o) return false end\n");
    write_script(dir, "throws", "PortMonitor.create = function(o) error('camera not calibrated') end\n");
    Daemon first(dir, "first", "", with_scripts(dir.file("scripts")));
    Daemon second(dir, "second", first.names(), with_scripts(dir.file("scripts")));
    auto sink = start_cli(dir, second, {"read", "/sink", "--timeout", "60"}, "sink");
    ASSERT_TRUE(wait_port(dir, first, "/sink"));
    CliWriter writer(dir, first, "/source", "writer");
    ASSERT_TRUE(wait_port(dir, first, "/source"));

    struct Case {
        std::string carrier;
        std::string expected;
    };
    const std::vector<Case> cases{
        {"tcp+recv.portmonitor+type.lua+file.broken", "broken.lua:2:"},
        {"tcp+send.portmonitor+type.lua+file.broken", "broken.lua:2:"},
        {"tcp+recv.portmonitor+type.lua+file.refuses", "'refuses' refused the connection"},
        {"tcp+send.portmonitor+type.lua+file.throws", "camera not calibrated"},
        {"tcp+recv.portmonitor+type.lua+file.missing", "'missing.lua' not found"},
        {"tcp+recv.portmonitor+type.lua+file.../etc/passwd", "must not contain '..'"},
        {"tcp+recv.portmonitor+type.lua+file./etc/passwd", "relative"},
        {"tcp+recv.portmonitor+type.python+file.certainty", "type.lua or type.so"},
        {"tcp+recv.portmonitor+type.lua", "without file.NAME"},
        {"tcp+recv.portmonitor+type.lua+file.certainty+onerror.maybe", "onerror.drop or onerror.pass"},
        // The send side loads, the recv side fails: the send side must be undone too.
        {"tcp+send.portmonitor+type.lua+file.certainty+recv.portmonitor+type.lua+file.broken",
         "broken.lua:2:"},
    };
    for (const auto& c : cases) {
        auto result = run_cli(dir, first, {"connect", "/source", "/sink", c.carrier});
        EXPECT_EQ(result.status, 4) << c.carrier;
        EXPECT_NE(result.err.find(c.expected), std::string::npos) << c.carrier << ": " << result.err;
        EXPECT_EQ(run_cli(dir, first, {"exists", "/source", "/sink"}).status, 1) << c.carrier;
    }
    auto stats = stats_of(dir, first, "/source");
    EXPECT_TRUE(stats["ports"][0]["outgoing"].empty());
    EXPECT_TRUE(stats_of(dir, second, "/sink")["ports"][0]["inbound"].empty());
    // Still usable afterwards.
    auto good =
        run_cli(dir, first, {"connect", "/source", "/sink", "tcp+recv.portmonitor+type.lua+file.certainty"});
    EXPECT_EQ(good.status, 0) << good.err;
}

TEST(Monitor_test, HostileMonitorsAreQuarantinedWhileOtherConnectionsKeepFlowing) {
    TempDir dir;
    std::filesystem::create_directories(dir.file("scripts"));
    write_script(
        dir, "spin",
        "PortMonitor.accept = function(msg) while true do pcall(function() while true do end end) end end\n");
    write_script(dir, "hog",
                 "PortMonitor.update = function(msg) hoard = hoard or {} while true do hoard[#hoard+1] = {} "
                 "end end\n");
    write_script(dir, "huge", "PortMonitor.accept = function(msg) return #string.rep('x', 2^30) > 0 end\n");
    write_script(
        dir, "escape",
        "PortMonitor.accept = function(msg) return os.execute('touch " + dir.file("escaped") + "') end\n");
    write_script(dir, "badport",
                 "PortMonitor.accept = function(msg) PortMonitor.publish('no/slash', 1) return true end\n");
    std::ofstream(dir.file("config.json")) << R"({"monitor_budget_ms": 30, "monitor_memory_bytes": 8388608,
                                                 "monitor_quarantine_after": 3})";
    auto args = with_scripts(dir.file("scripts"));
    args.push_back("--config");
    args.push_back(dir.file("config.json"));
    Daemon daemon(dir, "solo", "", args);

    const std::vector<std::string> hostile{"spin", "hog", "huge", "escape", "badport"};
    std::vector<Pipeline> pipelines;
    for (const auto& script : hostile) {
        pipelines.push_back(make_pipeline(dir, daemon, daemon, "/" + script + "/out", "/" + script + "/in",
                                          "tcp+recv.portmonitor+type.lua+file." + script, 100, script));
        ASSERT_EQ(pipelines.back().connected.status, 0) << pipelines.back().connected.err;
    }
    // A healthy connection with a monitor beside them.
    auto healthy = make_pipeline(dir, daemon, daemon, "/good/out", "/good/in",
                                 "tcp+recv.portmonitor+type.lua+file.certainty+threshold.0", 10000, "good");
    ASSERT_EQ(healthy.connected.status, 0) << healthy.connected.err;

    for (auto& p : pipelines)
        p.writer->send("1\n2\n3\n4\n5\n");
    std::string lines;
    for (int i = 0; i < 10000; ++i)
        lines += "{\"certainty\":1,\"i\":" + std::to_string(i) + "}\n";
    healthy.writer->send(lines);
    ASSERT_EQ(healthy.writer->finish(), 0);
    ASSERT_EQ(healthy.reader->wait(120s), 0) << healthy.reader->err();
    EXPECT_EQ(json_lines(healthy.reader->out()).size(), 10000u);

    for (const auto& script : hostile) {
        // "received" counts a message when it arrives, before the monitor's worker has run it:
        // wait for the monitor itself to have seen all five and closed its state.
        json monitor;
        ASSERT_TRUE(eventually([&] {
            auto inbound = stats_of(dir, daemon, "/" + script + "/in")["ports"][0]["inbound"][0];
            monitor = inbound["monitors"][0];
            return inbound["received"] == 5 && monitor["messages"] == 5 && monitor["quarantined"] == true &&
                   monitor["memory_bytes"] == 0;
        })) << script
            << ": " << monitor.dump();
        EXPECT_TRUE(monitor["quarantined"].get<bool>()) << script << ": " << monitor.dump();
        EXPECT_EQ(monitor["errors"], 3) << script;
        EXPECT_EQ(monitor["memory_bytes"], 0) << script;  // the state is closed, its memory returned
    }
    auto text_stats = run_cli(dir, daemon, {"stats"});
    EXPECT_NE(text_stats.out.find("QUARANTINED"), std::string::npos) << text_stats.out;
    EXPECT_FALSE(std::filesystem::exists(dir.file("escaped")));
    EXPECT_TRUE(daemon.process().running());
    // A memory bound: stretched by slowdown() in a sanitized build (shadow memory, redzones).
    EXPECT_LT(daemon.rss_kib(), static_cast<long>(64 * 1024 * slowdown()));
    auto log = (daemon.process().out() + daemon.process().err());
    EXPECT_NE(log.find("time budget of 30 ms exceeded"), std::string::npos);
    EXPECT_NE(log.find("not enough memory"), std::string::npos);
    EXPECT_NE(log.find("quarantined"), std::string::npos);
    for (auto& p : pipelines) {
        ASSERT_EQ(p.writer->finish(), 0);
        p.reader->signal(SIGTERM);
    }
}

}  // namespace monitor_test
}  // namespace plexus::test
