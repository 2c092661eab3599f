// plexus what-if on a live recording: the gaze demo's two detectors into /gaze/in (README,
// "Arbitration"), recorded by plexusd for a few seconds, re-run offline. With the recorded
// carriers every compared decision comes out as the daemon made it, with the stimulation alone
// and with the certainty monitor's events in play; with the object's inhibition weight at 0 some
// go the other way.
#include <gtest/gtest.h>

#include <sstream>

#include "harness.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/operations.hpp"

namespace plexus::test {
namespace what_if_test {

std::string detector_path() {
    return PLEXUS_DETECTOR_PATH;
}

/// The last line of `text`.
std::string last_line(const std::string& text) {
    std::istringstream lines(text);
    std::string line;
    std::string last;
    while (std::getline(lines, line)) {
        if (!line.empty())
            last = line;
    }
    return last;
}

/// Records /gaze/in into `path` until it holds `messages` messages, through libplexus's requests
/// (what `plexus record` sends).
void record_gaze(const Daemon& daemon, const std::string& path, std::uint64_t messages) {
    plexus::Client client({daemon.socket()});
    proto::RecordStartRequest start;
    start.ports = {"/gaze/in"};
    start.path = path;
    auto started = proto::RecordStartReply::decode(client.request(start.encode()));
    ASSERT_TRUE(started.ok()) << started.error().message;
    const auto status = [&](const nlohmann::json& body) {
        auto reply = proto::RecordStatusReply::decode(client.request(body));
        return reply.ok() ? reply->document : nlohmann::json::object();
    };
    const proto::RecordStatusRequest ask{started->id};
    EXPECT_TRUE(eventually([&] { return status(ask.encode()).value("messages", 0ull) >= messages; }, 30s));
    // The answer to record_stop comes once the file is closed; the recording is then forgotten.
    EXPECT_TRUE(status(proto::RecordStopRequest{started->id}.encode()).value("done", false));
}

struct GazeDemo {
    TempDir dir;
    Daemon daemon{dir, "one", "", {"--scripts", monitors_dir()}};
    std::unique_ptr<Process> reader = start_cli(dir, daemon, {"read", "/gaze/in"}, "gaze");
    // Short cycles, so that a few seconds hold hand-overs both ways.
    Process face{
        {detector_path(), "/demo/face/out", "--kind", "face", "--seen", "2", "--gone", "1", "--seed", "1"},
        daemon.env(),
        dir.file("face")};
    Process object{{detector_path(), "/demo/object/out", "--kind", "object", "--seen", "1", "--gone", "1",
                    "--offset", "0.5", "--seed", "2"},
                   daemon.env(),
                   dir.file("object")};

    void connect(const std::string& face_carrier, const std::string& object_carrier) {
        for (const char* port : {"/gaze/in", "/demo/face/out", "/demo/object/out"})
            ASSERT_TRUE(wait_port(dir, daemon, port)) << port;
        ASSERT_EQ(run_cli(dir, daemon, {"connect", "/demo/face/out", "/gaze/in", face_carrier}).status, 0);
        ASSERT_EQ(run_cli(dir, daemon, {"connect", "/demo/object/out", "/gaze/in", object_carrier}).status,
                  0);
    }
};

/// {"messages": N, "changed": K} of `plexus what-if ... --json`.
nlohmann::json summary_of(const CliResult& result) {
    EXPECT_EQ(result.status, 0) << result.err;
    auto summary = nlohmann::json::parse(last_line(result.out), nullptr, false);
    EXPECT_TRUE(summary.is_object()) << result.out;
    return summary;
}

TEST(WhatIf_test, TheRecordedGazeDemoComesOutAsRecordedAndOtherwiseWithoutTheInhibition) {
    GazeDemo demo;
    demo.connect("local+recv.priority+tc.0.5", "local+recv.priority+tc.0.5+ex./demo/face/out:-1");
    const std::string path = demo.dir.file("gaze.mcap");
    record_gaze(demo.daemon, path, 300);

    const auto same = run_cli(demo.dir, demo.daemon, {"what-if", path, "/gaze/in", "--json"});
    const auto summary = summary_of(same);
    EXPECT_GE(summary.value("messages", 0), 250) << same.out;
    EXPECT_EQ(summary.value("changed", -1), 0) << same.out;
    EXPECT_EQ(last_line(same.out).rfind("{\"messages\": ", 0), 0u) << "the exact shape tests rely on";

    const auto text = run_cli(demo.dir, demo.daemon,
                              {"what-if", path, "/gaze/in", "--carrier",
                               "/demo/object/out=local+recv.priority+tc.0.5+ex./demo/face/out:0", "--svg",
                               demo.dir.file("gaze.svg")});
    EXPECT_EQ(text.status, 0) << text.err;
    EXPECT_NE(text.out.find("winner changes"), std::string::npos) << text.out;

    const auto usage = run_cli(demo.dir, demo.daemon, {"what-if", path, "/not/recorded"});
    EXPECT_EQ(usage.status, 2) << usage.err;
    const auto not_mcap = run_cli(demo.dir, demo.daemon, {"what-if", demo.dir.file("face.out"), "/gaze/in"});
    EXPECT_EQ(not_mcap.status, 4) << not_mcap.err;
}

TEST(WhatIf_test, TheCertaintyMonitorsEventsComeOutAsRecorded) {
    GazeDemo demo;
    const std::string monitor = "recv.portmonitor+type.lua+file.certainty+threshold.0.5+lifetime.0.5";
    demo.connect("local+" + monitor + "+event.e_face_seen+recv.priority+tc.0.5",
                 "local+" + monitor + "+event.e_object_seen+recv.priority+tc.0.5+ex./demo/face/out:-1");
    const std::string path = demo.dir.file("gaze.mcap");
    record_gaze(demo.daemon, path, 300);
    const auto same =
        run_cli(demo.dir, demo.daemon, {"what-if", path, "/gaze/in", "--json", "--scripts", monitors_dir()});
    const auto summary = summary_of(same);
    EXPECT_GE(summary.value("messages", 0), 250) << same.out;
    EXPECT_EQ(summary.value("changed", -1), 0) << same.out;
}

}  // namespace what_if_test
}  // namespace plexus::test
