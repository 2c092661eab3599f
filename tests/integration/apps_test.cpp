// Application files end to end: `plexus up` starts components and makes connections, a second
// `up` changes nothing, `up --diff` sees drift, `up` repairs it, `down` leaves nothing running;
// a bad file changes nothing; components of a second daemon's node through --node-socket.
#include <signal.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "harness.hpp"

namespace plexus::test {
namespace apps_test {

/// The state directory `up` uses for a daemon: beside its socket.
std::string apps_dir(const Daemon& daemon) {
    return std::filesystem::path(daemon.socket()).parent_path().string() + "/apps";
}

/// The PIDs `up` recorded for application `name`.
std::vector<pid_t> recorded_pids(const Daemon& daemon, const std::string& name) {
    std::vector<pid_t> pids;
    std::ifstream in(apps_dir(daemon) + "/" + name + ".json");
    if (!in)
        return pids;
    const auto state = nlohmann::json::parse(in);
    for (const auto& [component, record] : state["components"].items())
        pids.push_back(record["pid"].get<pid_t>());
    return pids;
}

/// True when nothing runs as `pid` any more (an exited process waiting for its parent to reap it
/// runs nothing).
bool gone(pid_t pid) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    if (!in || !std::getline(in, line))
        return true;
    const auto close = line.rfind(')');
    return close != std::string::npos && close + 2 < line.size() && line[close + 2] == 'Z';
}

/// Kills what `up` started for these applications when the test ends, also when it fails: the
/// components outlive the `plexus up` that started them, so no Process handle holds them.
class StartedComponents {
public:
    StartedComponents(const Daemon& daemon, std::vector<std::string> names)
        : daemon_(daemon), names_(std::move(names)) {}
    ~StartedComponents() {
        for (const auto& name : names_) {
            for (const pid_t pid : recorded_pids(daemon_, name)) {
                if (!gone(pid))
                    ::kill(-pid, SIGKILL);
            }
        }
    }

private:
    const Daemon& daemon_;
    std::vector<std::string> names_;
};

/// Writes `text` as `name` in `dir`; returns its path.
std::string write_file(const TempDir& dir, const std::string& name, const std::string& text) {
    std::ofstream(dir.file(name)) << text;
    return dir.file(name);
}

/// A detector streaming into a reader, both started by `up`.
std::string sensor_app(const std::string& sink_node = "") {
    return R"({"name": "demo", "description": "a detector streaming into a reader",
  "components": [
    {"name": "sensor", "command": "plexus-detector",
     "args": ["/demo/sensor/out", "--gone", "0", "--rate", "${DEMO_RATE:-50}"], "ports": ["/demo/sensor/out"]},
    {"name": "sink", "command": "plexus", "args": ["read", "/demo/sink/in"], "node": ")" +
           sink_node + R"(", "ports": ["/demo/sink/in"]}
  ],
  "connections": [
    {"source": "/demo/sensor/out", "destination": "/demo/sink/in", "carrier": "tcp"}
  ]})";
}

nlohmann::json listed(const TempDir& dir, const Daemon& daemon) {
    auto list = run_cli(dir, daemon, {"list", "--json"});
    EXPECT_EQ(list.status, 0) << list.err;
    return nlohmann::json::parse(list.out);
}

/// The carrier of SRC -> DST in `plexus list`, or "" when there is no such connection.
std::string carrier_of(const TempDir& dir, const Daemon& daemon, const std::string& source,
                       const std::string& destination) {
    const auto live = listed(dir, daemon);  // named: a temporary would dangle in the loop
    for (const auto& c : live["connections"]) {
        if (c["source"] == source && c["destination"] == destination)
            return c["carrier"].get<std::string>();
    }
    return "";
}

bool port_listed(const TempDir& dir, const Daemon& daemon, const std::string& port) {
    const auto live = listed(dir, daemon);
    for (const auto& p : live["ports"]) {
        if (p["name"] == port)
            return true;
    }
    return false;
}

TEST(Apps_test, UpStartsAndConnectsIsIdempotentRepairsDriftAndDownLeavesNothing) {
    TempDir dir;
    Daemon daemon(dir, "alpha");
    StartedComponents cleanup(daemon, {"demo"});
    const auto file = write_file(dir, "demo.json", sensor_app());

    ASSERT_EQ(run_cli(dir, daemon, {"check", file}).status, 0);
    auto up = run_cli(dir, daemon, {"up", file});
    ASSERT_EQ(up.status, 0) << up.err;
    EXPECT_NE(up.out.find("started 2 (sensor, sink)"), std::string::npos) << up.out;
    EXPECT_NE(up.out.find("made 1"), std::string::npos) << up.out;
    const auto pids = recorded_pids(daemon, "demo");
    ASSERT_EQ(pids.size(), 2u);
    EXPECT_EQ(carrier_of(dir, daemon, "/demo/sensor/out", "/demo/sink/in"), "tcp");
    // Data flows: the reader's log fills with detections.
    const std::string sink_log = apps_dir(daemon) + "/demo/sink.log";
    EXPECT_TRUE(eventually([&] {
        return read_file(sink_log).find("\"kind\":\"object\"") != std::string::npos;
    })) << read_file(sink_log);

    auto again = run_cli(dir, daemon, {"up", file});
    ASSERT_EQ(again.status, 0) << again.err;
    EXPECT_NE(again.out.find("started 0"), std::string::npos) << again.out;
    EXPECT_NE(again.out.find("made 0, already there 1, replaced 0 (nothing to do)"), std::string::npos)
        << again.out;
    EXPECT_EQ(recorded_pids(daemon, "demo"), pids);
    EXPECT_EQ(run_cli(dir, daemon, {"up", file, "--diff"}).status, 0);

    // Drift: the connection removed by hand, and a connection the file does not have.
    ASSERT_EQ(run_cli(dir, daemon, {"disconnect", "/demo/sensor/out", "/demo/sink/in"}).status, 0);
    auto extra = start_cli(dir, daemon, {"read", "/demo/extra"}, "extra");
    ASSERT_TRUE(wait_port(dir, daemon, "/demo/extra"));
    ASSERT_EQ(run_cli(dir, daemon, {"connect", "/demo/extra", "/demo/sink/in"}).status, 0);
    auto diff = run_cli(dir, daemon, {"up", file, "--diff"});
    EXPECT_EQ(diff.status, 1) << diff.out << diff.err;
    EXPECT_NE(diff.out.find("/demo/sensor/out -> /demo/sink/in: missing"), std::string::npos) << diff.out;
    EXPECT_NE(diff.out.find("/demo/extra -> /demo/sink/in: not in the file"), std::string::npos) << diff.out;
    EXPECT_EQ(carrier_of(dir, daemon, "/demo/sensor/out", "/demo/sink/in"), "");  // --diff changed nothing

    auto repair = run_cli(dir, daemon, {"up", file});
    ASSERT_EQ(repair.status, 0) << repair.err;
    EXPECT_NE(repair.out.find("started 0"), std::string::npos) << repair.out;
    EXPECT_NE(repair.out.find("made 1"), std::string::npos) << repair.out;
    EXPECT_EQ(carrier_of(dir, daemon, "/demo/sensor/out", "/demo/sink/in"), "tcp");
    ASSERT_EQ(run_cli(dir, daemon, {"disconnect", "/demo/extra", "/demo/sink/in"}).status, 0);
    EXPECT_EQ(run_cli(dir, daemon, {"up", file, "--diff"}).status, 0);

    // Another carrier in the file: up replaces the connection and says so.
    std::string changed = sensor_app();
    changed.replace(changed.find("\"carrier\": \"tcp\""), 16, "\"carrier\": \"tcp+recv.priority+tc.0.5\"");
    write_file(dir, "demo.json", changed);
    auto drift = run_cli(dir, daemon, {"up", file, "--diff"});
    EXPECT_EQ(drift.status, 1);
    EXPECT_NE(drift.out.find("carrier tcp, the file has tcp+recv.priority+tc.0.5"), std::string::npos)
        << drift.out;
    auto replace = run_cli(dir, daemon, {"up", file});
    ASSERT_EQ(replace.status, 0) << replace.err;
    EXPECT_NE(replace.out.find("replaced 1"), std::string::npos) << replace.out;
    EXPECT_NE(replace.err.find("carrier was tcp"), std::string::npos) << replace.err;
    EXPECT_EQ(carrier_of(dir, daemon, "/demo/sensor/out", "/demo/sink/in"), "tcp+recv.priority+tc.0.5");

    auto down = run_cli(dir, daemon, {"down", file});
    ASSERT_EQ(down.status, 0) << down.err;
    EXPECT_NE(down.out.find("removed 1 connection, stopped 2 components"), std::string::npos) << down.out;
    for (const pid_t pid : pids)
        EXPECT_TRUE(gone(pid)) << "pid " << pid << " still runs after down";
    EXPECT_EQ(carrier_of(dir, daemon, "/demo/sensor/out", "/demo/sink/in"), "");
    EXPECT_FALSE(std::filesystem::exists(apps_dir(daemon) + "/demo.json"));
    EXPECT_TRUE(eventually([&] { return !port_listed(dir, daemon, "/demo/sensor/out"); }));
    EXPECT_TRUE(eventually([&] { return !port_listed(dir, daemon, "/demo/sink/in"); }));
}

TEST(Apps_test, ABadFileMakesCheckAndUpExit2AndChangesNothing) {
    TempDir dir;
    Daemon daemon(dir, "alpha");
    StartedComponents cleanup(daemon, {"demo"});
    std::string bad = sensor_app();
    bad.replace(bad.find("\"carrier\": \"tcp\""), 16,
                "\"carrier\": \"tcp+recv.bogus\", \"persistent\": true");
    const auto file = write_file(dir, "bad.json", bad);

    auto check = run_cli(dir, daemon, {"check", file});
    EXPECT_EQ(check.status, 2);
    EXPECT_NE(
        check.err.find(file + ": connections[0] /demo/sensor/out -> /demo/sink/in: \"carrier\": unknown "
                              "modifier 'recv.bogus'"),
        std::string::npos)
        << check.err;
    EXPECT_NE(check.err.find("unknown field \"persistent\""), std::string::npos) << check.err;

    auto up = run_cli(dir, daemon, {"up", file});
    EXPECT_EQ(up.status, 2);
    EXPECT_NE(up.err.find("nothing was started or connected"), std::string::npos) << up.err;
    EXPECT_FALSE(std::filesystem::exists(apps_dir(daemon)));  // no state, no log: nothing started
    const auto live = listed(dir, daemon);
    EXPECT_TRUE(live["ports"].empty()) << live.dump();
    EXPECT_TRUE(live["connections"].empty()) << live.dump();

    // An unset variable without a default is as bad.
    std::string unset = sensor_app();
    unset.replace(unset.find("${DEMO_RATE:-50}"), 16, "${DEMO_UNSET_RATE}");
    auto unset_up = run_cli(dir, daemon, {"up", write_file(dir, "unset.json", unset)});
    EXPECT_EQ(unset_up.status, 2);
    EXPECT_NE(unset_up.err.find("components[0] \"sensor\": \"args[4]\": variable DEMO_UNSET_RATE is not set"),
              std::string::npos)
        << unset_up.err;
    EXPECT_FALSE(std::filesystem::exists(apps_dir(daemon)));
}

TEST(Apps_test, AComponentWhosePortsNeverAppearTimesOutAndUpUndoesItself) {
    TempDir dir;
    Daemon daemon(dir, "alpha");
    StartedComponents cleanup(daemon, {"demo"});
    std::string app = sensor_app();
    // The reader opens /demo/sink/in, but the file waits for a port nobody opens.
    app.replace(app.find("\"ports\": [\"/demo/sink/in\"]"), 26, "\"ports\": [\"/demo/never\"]");
    const auto file = write_file(dir, "demo.json", app);
    auto up = run_cli(dir, daemon, {"up", file, "--timeout", "2"});
    EXPECT_EQ(up.status, 3) << up.err;
    EXPECT_NE(
        up.err.find("/demo/never (of component sink; see its log " + apps_dir(daemon) + "/demo/sink.log)"),
        std::string::npos)
        << up.err;
    EXPECT_NE(up.err.find("undo: stopped sensor"), std::string::npos) << up.err;
    EXPECT_FALSE(std::filesystem::exists(apps_dir(daemon) + "/demo.json"));
    EXPECT_TRUE(eventually([&] { return listed(dir, daemon)["ports"].empty(); }));
    EXPECT_TRUE(listed(dir, daemon)["connections"].empty());
}

TEST(Apps_test, AComponentThatExitsMakesUpFailWith4AndStopWhatItStarted) {
    TempDir dir;
    Daemon daemon(dir, "alpha");
    StartedComponents cleanup(daemon, {"demo"});
    std::string app = sensor_app();
    app.replace(app.find("\"args\": [\"read\", \"/demo/sink/in\"]"), 33, "\"args\": [\"read\"]");
    const auto file = write_file(dir, "demo.json", app);
    auto up = run_cli(dir, daemon, {"up", file});
    EXPECT_EQ(up.status, 4) << up.err;
    EXPECT_NE(up.err.find("component sink exited with status 2"), std::string::npos) << up.err;
    EXPECT_NE(up.err.find("undo: stopped sensor"), std::string::npos) << up.err;
    EXPECT_TRUE(eventually([&] { return listed(dir, daemon)["ports"].empty(); }));
}

TEST(Apps_test, ComponentsOfAnotherNodeStartUnderItsDaemonWithNodeSocket) {
    TempDir dir;
    Daemon alpha(dir, "alpha");
    TempDir beta_dir;
    Daemon beta(beta_dir, "beta", alpha.names());
    StartedComponents cleanup(alpha, {"demo"});
    const auto file = write_file(dir, "demo.json", sensor_app("beta"));

    auto unknown = run_cli(dir, alpha, {"up", file});
    EXPECT_EQ(unknown.status, 2);
    EXPECT_NE(unknown.err.find("components[1] \"sink\": \"node\": no daemon socket known for node 'beta'"),
              std::string::npos)
        << unknown.err;
    EXPECT_NE(unknown.err.find("--node-socket beta=PATH"), std::string::npos) << unknown.err;
    EXPECT_NE(unknown.err.find("--only-node beta"), std::string::npos) << unknown.err;
    EXPECT_TRUE(listed(dir, alpha)["ports"].empty());

    auto up = run_cli(dir, alpha, {"up", file, "--node-socket", "beta=" + beta.socket()});
    ASSERT_EQ(up.status, 0) << up.err;
    std::map<std::string, std::string> nodes;
    const auto live = listed(dir, alpha);
    for (const auto& p : live["ports"])
        nodes[p["name"]] = p["node"];
    EXPECT_EQ(nodes["/demo/sensor/out"], "alpha");
    EXPECT_EQ(nodes["/demo/sink/in"], "beta");
    EXPECT_EQ(carrier_of(dir, alpha, "/demo/sensor/out", "/demo/sink/in"), "tcp");
    EXPECT_EQ(run_cli(dir, alpha, {"up", file, "--node-socket", "beta=" + beta.socket(), "--diff"}).status,
              0);

    const auto pids = recorded_pids(alpha, "demo");
    auto down = run_cli(dir, alpha, {"down", file});
    ASSERT_EQ(down.status, 0) << down.err;
    for (const pid_t pid : pids)
        EXPECT_TRUE(gone(pid)) << "pid " << pid << " still runs after down";
    EXPECT_EQ(carrier_of(dir, alpha, "/demo/sensor/out", "/demo/sink/in"), "");
}

}  // namespace apps_test
}  // namespace plexus::test
