// Arbitration end to end with real processes (DESIGN, "Arbitration by events and constraints",
// "Arbitration by stimulation", "Inspecting the live system"): competing sources into one input
// port, the CLI connecting them with carrier strings, `plexus events` showing the decision.
//
// Streams are paced with a sleep between lines (that is what a periodic sensor does); every
// wait for an outcome polls a condition against a deadline. The exact timing of the decay is
// proven in tests/unit/daemon with a clock the test moves; here we prove the behaviour.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "harness.hpp"

namespace plexus::test {
namespace arbitration_test {

using nlohmann::json;

std::vector<std::string> with_scripts() {
    return {"--scripts", monitors_dir()};
}

json events_of(const TempDir& dir, const Daemon& daemon, const std::string& port, bool check = false) {
    std::vector<std::string> args{"events", port, "--json"};
    if (check)
        args.push_back("--check");
    auto result = run_cli(dir, daemon, args);
    EXPECT_TRUE(result.status == 0 || (check && result.status == 1)) << result.err;
    if (result.out.empty())
        ADD_FAILURE() << "events gave nothing: status " << result.status << " " << result.err;
    return json::parse(result.out);
}

/// The `plexus events` entry of the connection from `source`; null if it is not there.
json connection_of(const json& events, const std::string& source) {
    for (const auto& c : events["connections"]) {
        if (c["source"] == source)
            return c;
    }
    return nullptr;
}

std::uint64_t counter(const TempDir& dir, const Daemon& daemon, const std::string& port,
                      const std::string& source, const char* name) {
    auto c = connection_of(events_of(dir, daemon, port), source);
    return c.is_null() ? 0 : c["counters"][name].get<std::uint64_t>();
}

void connect_ok(const TempDir& dir, const Daemon& daemon, const std::string& source,
                const std::string& destination, const std::string& carrier) {
    auto result = run_cli(dir, daemon, {"connect", source, destination, carrier});
    ASSERT_EQ(result.status, 0) << result.err;
}

/// A writer that sends the same line every `period` from a thread, until stopped.
class Stream {
public:
    Stream(CliWriter& writer, std::string line, std::chrono::milliseconds period = 20ms)
        : writer_(writer), line_(std::move(line) + "\n"), period_(period) {}
    ~Stream() { stop(); }
    void start() {
        stop();
        running_ = true;
        thread_ = std::thread([this] {
            while (running_) {
                writer_.send(line_);
                std::this_thread::sleep_for(period_);
            }
        });
    }
    void stop() {
        running_ = false;
        if (thread_.joinable())
            thread_.join();
    }

private:
    CliWriter& writer_;
    std::string line_;
    std::chrono::milliseconds period_;
    std::atomic<bool> running_{false};
    std::thread thread_;
};

/// How many messages of that connection its monitors (if any) and the arbiter have judged. Not
/// `received`: that counts a message on arrival, before a monitor's worker has run it.
std::uint64_t judged(const TempDir& dir, const Daemon& daemon, const std::string& port,
                     const std::string& source) {
    return counter(dir, daemon, port, source, "accepted") +
           counter(dir, daemon, port, source, "dropped_by_accept");
}

/// Sends one line and waits until the daemon has judged it on that connection, so that messages
/// of two writers reach the port, and its events, in a known order.
void send_and_wait(const TempDir& dir, const Daemon& daemon, CliWriter& writer, const std::string& port,
                   const std::string& source, const std::string& line) {
    const auto before = judged(dir, daemon, port, source);
    writer.send(line + "\n");
    ASSERT_TRUE(eventually([&] { return judged(dir, daemon, port, source) > before; }))
        << "the daemon never judged " << line << " from " << source;
}

TEST(Arbitration_test, GazeObjectInhibitsFaceWhileBothStreamAndFaceReturnsAfterTheObjectStops) {
    TempDir dir;
    Daemon daemon(dir, "robot", "", with_scripts());
    auto reader =
        start_cli(dir, daemon, {"read", "/gaze/in", "--policy", "latest", "--queue", "100000"}, "gaze");
    ASSERT_TRUE(wait_port(dir, daemon, "/gaze/in"));
    CliWriter face(dir, daemon, "/face/out", "face");
    CliWriter object(dir, daemon, "/obj/out", "object");
    ASSERT_TRUE(wait_port(dir, daemon, "/face/out"));
    ASSERT_TRUE(wait_port(dir, daemon, "/obj/out"));
    const double tc = 0.5;
    connect_ok(dir, daemon, "/face/out", "/gaze/in", "tcp+recv.priority+tc.0.5+st.1+bs.1");
    connect_ok(dir, daemon, "/obj/out", "/gaze/in", "tcp+recv.priority+tc.0.5+st.1+bs.1+ex./face/out:-1");

    Stream faces(face, R"({"face":[0.1,0.2]})");
    Stream objects(object, R"({"object":[0.5,0.5]})");
    faces.start();
    objects.start();
    // Once the object is delivered, it is the winner: face data stops while both stream.
    ASSERT_TRUE(eventually([&] { return counter(dir, daemon, "/gaze/in", "/obj/out", "delivered") >= 10; }));
    const auto face_delivered = counter(dir, daemon, "/gaze/in", "/face/out", "delivered");
    const auto face_received = counter(dir, daemon, "/gaze/in", "/face/out", "received");
    ASSERT_TRUE(eventually(
        [&] { return counter(dir, daemon, "/gaze/in", "/face/out", "received") >= face_received + 25; }));
    auto state = events_of(dir, daemon, "/gaze/in");
    EXPECT_EQ(connection_of(state, "/face/out")["counters"]["delivered"], face_delivered)
        << "face data got through while the object streamed: " << state.dump();
    EXPECT_GE(connection_of(state, "/face/out")["counters"]["dropped_by_priority"], 25u);
    EXPECT_EQ(state["winner"], "/obj/out");
    EXPECT_EQ(connection_of(state, "/obj/out")["priority"]["x"], 1);
    EXPECT_NEAR(connection_of(state, "/obj/out")["priority"]["y"].get<double>(), 1.0, 1e-9);
    EXPECT_NEAR(connection_of(state, "/face/out")["priority"]["y"].get<double>(), 0.0, 1e-9);

    // The object stops; after its stimulation decays (tc), face data flows again.
    objects.stop();
    const auto stopped = std::chrono::steady_clock::now();
    ASSERT_TRUE(eventually(
        [&] { return counter(dir, daemon, "/gaze/in", "/face/out", "delivered") > face_delivered; }));
    const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - stopped).count();
    EXPECT_LT(took, tc + 1.5) << "face data came back only after " << took << " s (tc is " << tc << " s)";
    EXPECT_EQ(events_of(dir, daemon, "/gaze/in")["winner"], "/face/out");
    faces.stop();
}

TEST(Arbitration_test, AnAuxiliaryFaceConnectionExcitesTheObjectConnection) {
    TempDir dir;
    Daemon daemon(dir, "robot", "", with_scripts());
    auto reader =
        start_cli(dir, daemon, {"read", "/gaze/in", "--policy", "latest", "--queue", "100000"}, "gaze");
    ASSERT_TRUE(wait_port(dir, daemon, "/gaze/in"));
    CliWriter face(dir, daemon, "/face/out", "face");
    CliWriter object(dir, daemon, "/obj/out", "object");
    ASSERT_TRUE(wait_port(dir, daemon, "/face/out"));
    ASSERT_TRUE(wait_port(dir, daemon, "/obj/out"));
    connect_ok(dir, daemon, "/face/out", "/gaze/in", "tcp+recv.priority+aux+tc.0.3+ex./obj/out:1");
    connect_ok(dir, daemon, "/obj/out", "/gaze/in", "tcp+recv.priority+tc.0.3+bs.0");
    Stream faces(face, R"({"face":[0.1,0.2]})");
    Stream objects(object, R"({"object":[0.5,0.5]})");

    // Objects alone: bias 0, nothing excites them, nothing is delivered.
    objects.start();
    ASSERT_TRUE(eventually([&] { return counter(dir, daemon, "/gaze/in", "/obj/out", "received") >= 20; }));
    EXPECT_EQ(counter(dir, daemon, "/gaze/in", "/obj/out", "delivered"), 0u);

    // Faces seen too: the auxiliary face connection excites the object one.
    faces.start();
    ASSERT_TRUE(eventually([&] { return counter(dir, daemon, "/gaze/in", "/obj/out", "delivered") >= 10; }));

    // Faces gone: once the face connection is no longer active, objects stop getting through.
    faces.stop();
    ASSERT_TRUE(eventually([&] {
        auto c = connection_of(events_of(dir, daemon, "/gaze/in"), "/face/out");
        return c["priority"]["x"] == 0;
    }));
    const auto delivered = counter(dir, daemon, "/gaze/in", "/obj/out", "delivered");
    const auto received = counter(dir, daemon, "/gaze/in", "/obj/out", "received");
    ASSERT_TRUE(eventually(
        [&] { return counter(dir, daemon, "/gaze/in", "/obj/out", "received") >= received + 20; }));
    objects.stop();
    auto state = events_of(dir, daemon, "/gaze/in");
    EXPECT_EQ(connection_of(state, "/obj/out")["counters"]["delivered"], delivered);
    // Face data is never delivered: the connection is auxiliary.
    EXPECT_EQ(connection_of(state, "/face/out")["counters"]["delivered"], 0);
    EXPECT_EQ(connection_of(state, "/face/out")["aux"], true);
}

TEST(Arbitration_test, TwoTrackersTheMoreTrustedWinsAndCheckFindsOverlapsWithAWitness) {
    TempDir dir;
    Daemon first(dir, "head", "", with_scripts());
    Daemon second(dir, "vision", first.names(), with_scripts());
    auto reader =
        start_cli(dir, first, {"read", "/head/in"}, "head-reader");  // stays: /head/in lives with it
    ASSERT_TRUE(wait_port(dir, first, "/head/in"));
    CliWriter templ(dir, first, "/tmpl/out", "template");
    CliWriter particle(dir, second, "/pf/out", "particle");  // on another daemon: the tcp link path
    ASSERT_TRUE(wait_port(dir, first, "/tmpl/out"));
    ASSERT_TRUE(wait_port(dir, first, "/pf/out"));
    const std::string monitor = "tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.6+keep";
    connect_ok(dir, first, "/tmpl/out", "/head/in",
               monitor + "+event.e_template_ok+constraint.e_template_ok and not e_particle_ok");
    connect_ok(dir, first, "/pf/out", "/head/in", monitor + "+event.e_particle_ok+constraint.e_particle_ok");

    auto check = run_cli(dir, first, {"events", "/head/in", "--check"});
    EXPECT_EQ(check.status, 0) << check.out << check.err;

    auto send = [&](CliWriter& writer, const std::string& source, const std::string& line) {
        send_and_wait(dir, first, writer, "/head/in", source, line);
    };
    send(templ, "/tmpl/out", R"({"t":1,"certainty":0.9})");   // template ok, particle not: delivered
    send(particle, "/pf/out", R"({"p":1,"certainty":0.3})");  // particle not ok: dropped
    send(particle, "/pf/out", R"({"p":2,"certainty":0.8})");  // particle ok: delivered
    send(templ, "/tmpl/out", R"({"t":2,"certainty":0.95})");  // particle trusted more: dropped
    send(particle, "/pf/out", R"({"p":3,"certainty":0.2})");  // particle lost: dropped
    send(templ, "/tmpl/out", R"({"t":3,"certainty":0.9})");   // template again: delivered
    std::vector<json> lines;
    ASSERT_TRUE(eventually([&] { return (lines = json_lines(reader->out())).size() >= 3u; }))
        << reader->out();
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_EQ(lines[0]["t"], 1);
    EXPECT_EQ(lines[1]["p"], 2);
    EXPECT_EQ(lines[2]["t"], 3);

    auto state = events_of(dir, first, "/head/in");
    EXPECT_EQ(connection_of(state, "/tmpl/out")["counters"]["dropped_by_constraint"], 1);
    EXPECT_EQ(connection_of(state, "/pf/out")["counters"]["dropped_by_constraint"], 2);
    EXPECT_EQ(connection_of(state, "/tmpl/out")["constraint"], "e_template_ok and not e_particle_ok");
    ASSERT_EQ(state["events"].size(), 1u) << state.dump();
    EXPECT_EQ(state["events"][0]["name"], "e_template_ok");
    EXPECT_EQ(state["events"][0]["owner"], "/tmpl/out (certainty)");

    // The same counters in plexus stats.
    auto stats = json::parse(run_cli(dir, first, {"stats", "/head/in", "--json"}).out);
    EXPECT_EQ(stats["ports"][0]["inbound"][0]["dropped_by_constraint"], 1);

    // A looser first constraint overlaps the second: connect warns, --check reports a witness.
    auto disconnected = run_cli(dir, first, {"disconnect", "/tmpl/out", "/head/in"});
    ASSERT_EQ(disconnected.status, 0) << disconnected.err;
    auto strict = run_cli(dir, first,
                          {"connect", "/tmpl/out", "/head/in",
                           monitor + "+event.e_template_ok+constraint.e_template_ok", "--strict"});
    EXPECT_EQ(strict.status, 4);
    EXPECT_NE(strict.err.find("can both deliver"), std::string::npos) << strict.err;
    EXPECT_EQ(run_cli(dir, first, {"exists", "/tmpl/out", "/head/in"}).status, 1)
        << "--strict left it connected";
    auto loose = run_cli(
        dir, first,
        {"connect", "/tmpl/out", "/head/in", monitor + "+event.e_template_ok+constraint.e_template_ok"});
    ASSERT_EQ(loose.status, 0) << loose.err;
    EXPECT_NE(
        loose.err.find("warning: connections from /pf/out and /tmpl/out into /head/in can both deliver"),
        std::string::npos)
        << loose.err;
    auto overlap = run_cli(dir, first, {"events", "/head/in", "--check", "--json"});
    EXPECT_EQ(overlap.status, 1) << overlap.err;
    auto report = json::parse(overlap.out);
    ASSERT_EQ(report["overlaps"].size(), 1u) << report.dump();
    EXPECT_EQ(report["overlaps"][0]["witness"],
              json::parse(R"({"e_particle_ok":true,"e_template_ok":true})"));
    auto text = run_cli(dir, first, {"events", "/head/in", "--check"});
    EXPECT_EQ(text.status, 1);
    EXPECT_NE(text.out.find("e_particle_ok present, e_template_ok present"), std::string::npos) << text.out;

    // --strict through the tcp link: the receiving daemon refuses in attach.
    ASSERT_EQ(run_cli(dir, first, {"disconnect", "/pf/out", "/head/in"}).status, 0);
    auto remote_strict = run_cli(dir, second, {"connect", "/pf/out", "/head/in", "tcp", "--strict"});
    EXPECT_EQ(remote_strict.status, 4) << remote_strict.err;
    EXPECT_EQ(run_cli(dir, first, {"exists", "/pf/out", "/head/in"}).status, 1);
}

TEST(Arbitration_test, AnEventWithALifetimeThatIsNotRefreshedReleasesTheOtherSource) {
    TempDir dir;
    Daemon daemon(dir, "robot", "", with_scripts());
    auto reader = start_cli(dir, daemon, {"read", "/track/in"}, "track");
    ASSERT_TRUE(wait_port(dir, daemon, "/track/in"));
    CliWriter primary(dir, daemon, "/primary/out", "primary");
    CliWriter backup(dir, daemon, "/backup/out", "backup");
    ASSERT_TRUE(wait_port(dir, daemon, "/primary/out"));
    ASSERT_TRUE(wait_port(dir, daemon, "/backup/out"));
    connect_ok(dir, daemon, "/primary/out", "/track/in",
               "tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.5+event.e_primary_ok+lifetime.0.5"
               "+constraint.e_primary_ok");
    connect_ok(dir, daemon, "/backup/out", "/track/in", "tcp+recv.portmonitor+constraint.not e_primary_ok");

    const auto set_at = std::chrono::steady_clock::now();
    send_and_wait(dir, daemon, primary, "/track/in", "/primary/out", R"({"n":1,"certainty":0.9})");
    auto state = events_of(dir, daemon, "/track/in");
    if (!state["events"].empty()) {
        EXPECT_EQ(state["events"][0]["name"], "e_primary_ok");
        EXPECT_LE(state["events"][0]["time_left"].get<double>(), 0.5);
    }
    // Sent while the event most likely lives: held back. (On a machine that took 0.5 s to get
    // here it is delivered instead; the counters below tell which.)
    send_and_wait(dir, daemon, backup, "/track/in", "/backup/out", R"({"n":2})");
    ASSERT_TRUE(eventually([&] { return events_of(dir, daemon, "/track/in")["events"].empty(); }));
    const double expired_after =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - set_at).count();
    EXPECT_GE(expired_after, 0.5) << "the event expired before its lifetime";
    const bool held_back = counter(dir, daemon, "/track/in", "/backup/out", "dropped_by_constraint") == 1;
    send_and_wait(dir, daemon, backup, "/track/in", "/backup/out", R"({"n":3})");
    std::vector<json> lines;
    ASSERT_TRUE(eventually([&] {
        lines = json_lines(reader->out());
        return !lines.empty() && lines.back()["n"] == 3;
    })) << reader->out();
    std::vector<int> got;
    for (const auto& line : lines)
        got.push_back(line["n"]);
    EXPECT_EQ(got, held_back ? std::vector<int>({1, 3}) : std::vector<int>({1, 2, 3}));
}

TEST(Arbitration_test, QualityOfServiceLetsTheBackupThroughWhileThePrimaryIsSilent) {
    TempDir dir;
    Daemon daemon(dir, "robot", "", with_scripts());
    auto reader = start_cli(dir, daemon, {"read", "/img/in"}, "img");
    ASSERT_TRUE(wait_port(dir, daemon, "/img/in"));
    CliWriter main_camera(dir, daemon, "/cam/main", "main");
    CliWriter backup_camera(dir, daemon, "/cam/backup", "backup");
    ASSERT_TRUE(wait_port(dir, daemon, "/cam/main"));
    ASSERT_TRUE(wait_port(dir, daemon, "/cam/backup"));
    connect_ok(dir, daemon, "/cam/main", "/img/in",
               "tcp+recv.portmonitor+type.lua+file.qos+timeout.1+port./img/qos+event.e_qos_not_ok"
               "+constraint.not e_qos_not_ok");
    connect_ok(dir, daemon, "/cam/backup", "/img/in", "tcp+recv.portmonitor+constraint.e_qos_not_ok");
    EXPECT_EQ(run_cli(dir, daemon, {"events", "/img/in", "--check"}).status, 0);

    auto send = [&](CliWriter& writer, const std::string& source, const std::string& line) {
        send_and_wait(dir, daemon, writer, "/img/in", source, line);
    };
    send(main_camera, "/cam/main", R"({"from":"main","n":1})");
    // The main camera flows (unless this machine stalled for 1 s): the backup is held back.
    send(backup_camera, "/cam/backup", R"({"from":"backup","n":0})");
    const bool held_back = counter(dir, daemon, "/img/in", "/cam/backup", "dropped_by_constraint") == 1;
    // The main camera goes silent: its qos monitor's trig raises e_qos_not_ok.
    ASSERT_TRUE(eventually([&] {
        auto events = events_of(dir, daemon, "/img/in")["events"];
        return events.size() == 1u && events[0]["name"] == "e_qos_not_ok";
    }));
    send(backup_camera, "/cam/backup", R"({"from":"backup","n":2})");
    // It comes back: accept clears the event before the constraint is evaluated.
    send(main_camera, "/cam/main", R"({"from":"main","n":3})");
    std::vector<json> lines;
    ASSERT_TRUE(eventually([&] {
        lines = json_lines(reader->out());
        return !lines.empty() && lines.back()["n"] == 3;
    })) << reader->out();
    std::vector<int> got;
    for (const auto& line : lines)
        got.push_back(line["n"]);
    EXPECT_EQ(got, held_back ? std::vector<int>({1, 2, 3}) : std::vector<int>({1, 0, 2, 3}));
    // And the backup is held back again now that the main camera is back.
    send(backup_camera, "/cam/backup", R"({"from":"backup","n":4})");
    EXPECT_EQ(counter(dir, daemon, "/img/in", "/cam/backup", "dropped_by_constraint"), held_back ? 2u : 1u);
}

TEST(Arbitration_test, ConnectRefusesBadConstraintsAndInconsistentWeightsLeavingNothingConnected) {
    TempDir dir;
    Daemon daemon(dir, "robot", "", with_scripts());
    auto reader = start_cli(dir, daemon, {"read", "/in"}, "in");
    ASSERT_TRUE(wait_port(dir, daemon, "/in"));
    CliWriter a(dir, daemon, "/a/out", "a");
    CliWriter b(dir, daemon, "/b/out", "b");
    ASSERT_TRUE(wait_port(dir, daemon, "/a/out"));
    ASSERT_TRUE(wait_port(dir, daemon, "/b/out"));

    auto bad =
        run_cli(dir, daemon, {"connect", "/a/out", "/in", "tcp+recv.portmonitor+constraint.e_x and (e_y or"});
    EXPECT_EQ(bad.status, 4);
    EXPECT_NE(bad.err.find("at position 15"), std::string::npos) << bad.err;
    auto sent = run_cli(dir, daemon, {"connect", "/a/out", "/in", "tcp+send.priority+tc.1"});
    EXPECT_EQ(sent.status, 4);
    EXPECT_NE(sent.err.find("recv.priority"), std::string::npos) << sent.err;
    auto key = run_cli(dir, daemon, {"connect", "/a/out", "/in", "tcp+recv.priority+speed.2"});
    EXPECT_EQ(key.status, 4);
    EXPECT_NE(key.err.find("'speed'"), std::string::npos) << key.err;
    EXPECT_EQ(run_cli(dir, daemon, {"exists", "/a/out", "/in"}).status, 1);

    // Mutual excitation with weight 1 both ways: I - X*A^T is singular when both are active.
    connect_ok(dir, daemon, "/a/out", "/in", "tcp+recv.priority+ex./b/out:1");
    auto singular = run_cli(dir, daemon, {"connect", "/b/out", "/in", "tcp+recv.priority+ex./a/out:1"});
    EXPECT_EQ(singular.status, 4);
    EXPECT_NE(singular.err.find("inconsistent weights"), std::string::npos) << singular.err;
    EXPECT_EQ(run_cli(dir, daemon, {"exists", "/b/out", "/in"}).status, 1);
    connect_ok(dir, daemon, "/b/out", "/in", "tcp+recv.priority+ex./a/out:0.5");

    auto missing = run_cli(dir, daemon, {"events", "/nowhere"});
    EXPECT_EQ(missing.status, 4);
    auto watched =
        run_cli(dir, daemon, {"events", "/in", "--watch", "--json", "--count", "2", "--interval", "0.05"});
    ASSERT_EQ(watched.status, 0) << watched.err;
    auto frames = json_lines(watched.out);
    ASSERT_EQ(frames.size(), 2u);
    EXPECT_EQ(frames[1]["connections"].size(), 2u);
}

}  // namespace arbitration_test
}  // namespace plexus::test
