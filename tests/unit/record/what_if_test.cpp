// plexus what-if's re-run (tools/record/what_if.hpp) on recordings written here, whose decisions
// come from the daemon's own arbitration and monitors run live by the test (recording_fixture.hpp).
#include "what_if.hpp"

#include <gtest/gtest.h>

#include <random>

#include "recording_fixture.hpp"
#include "timeline_svg.hpp"

namespace plexus::record {
namespace {

using test::LivePort;
using test::RecordingWriter;
using test::started_clock;

const std::string port_name = "/gaze/in";
const std::string face_carrier = "local+recv.priority+tc.0.5";
const std::string object_carrier = "local+recv.priority+tc.0.5+ex./face/out:-1";
const std::string object_without_inhibition = "local+recv.priority+tc.0.5+ex./face/out:0";

proto::Bytes cbor(const nlohmann::json& value) {
    return nlohmann::json::to_cbor(value);
}

RecordedPort read(const std::string& path, const std::string& port = port_name) {
    auto reader = mcap::Reader::open(path);
    EXPECT_TRUE(reader.ok()) << (reader.ok() ? "" : reader.error().message);
    auto recorded = read_recorded_port(*reader, port);
    EXPECT_TRUE(recorded.ok()) << (recorded.ok() ? "" : recorded.error().message);
    return std::move(*recorded);
}

WhatIfResult run(const RecordedPort& port, WhatIfOptions options = {}) {
    auto result = what_if(port, options);
    EXPECT_TRUE(result.ok()) << (result.ok() ? "" : result.error().message);
    return std::move(*result);
}

const MessageDecision& decision_of(const WhatIfResult& result, const std::string& source, std::uint64_t seq) {
    for (const auto& decision : result.decisions) {
        if (decision.source == source && decision.seq == seq)
            return decision;
    }
    ADD_FAILURE() << "no decision for " << source << " seq " << seq;
    return result.decisions.front();
}

/// The gaze pair of the README by hand: the object inhibits the face; five messages whose fate
/// is worked out on paper in the test below.
struct HandRecording {
    test::TempDir dir;
    std::string path = dir.file("gaze.mcap");

    HandRecording() {
        RecordingWriter writer(path, port_name);
        writer.connection("/face/out", face_carrier, 0);
        writer.connection("/obj/out", object_carrier, 1);
        LivePort live(port_name, {{"/face/out", face_carrier}, {"/obj/out", object_carrier}}, dir.file(""));
        struct Sent {
            std::string source;
            std::uint64_t seq;
            double at;
            bool decided_with_times;
        };
        const std::vector<Sent> sent{{"/face/out", 1, 0.10, true}, {"/obj/out", 1, 0.20, true},
                                     {"/face/out", 2, 0.30, true}, {"/obj/out", 2, 0.40, true},
                                     {"/face/out", 3, 1.00, true}, {"/obj/out", 3, 1.45, false}};
        for (const auto& m : sent) {
            const double t = started_clock + m.at;
            writer.message(m.source, m.seq, t, cbor(m.seq));
            const std::string outcome = live.decide(m.source, m.seq, cbor(m.seq), t, t);
            // The last one as a decision of a batch run: no times, so its arrival stands in.
            writer.decision(m.source, m.seq, outcome, m.decided_with_times ? t : 0,
                            m.decided_with_times ? t : 0);
        }
        // In flight when the recording stopped: a message with no decision.
        writer.message("/face/out", 4, started_clock + 1.6, cbor(4));
        writer.close();
    }
};

TEST(WhatIf_test, TheRecordedCarriersReproduceEveryRecordedDecision) {
    HandRecording recording;
    const auto port = read(recording.path);
    ASSERT_EQ(port.connections.size(), 2u);
    EXPECT_EQ(port.connections[0].source, "/face/out");
    const auto result = run(port);
    EXPECT_EQ(result.changed, 0u);
    EXPECT_EQ(result.undecided, 1u) << "face seq 4 was in flight at the end";
    EXPECT_EQ(result.warm_up, 0u) << "face seq 1 came before the object's state was known, but the "
                                     "re-run from an empty past reproduces it: it is compared";
    EXPECT_EQ(result.compared, 6u);
    EXPECT_EQ(decision_of(result, "/face/out", 2).recorded, "priority");
    EXPECT_EQ(decision_of(result, "/obj/out", 3).recorded, "delivered");
    EXPECT_EQ(decision_of(result, "/obj/out", 3).what_if, "delivered");
    EXPECT_EQ(result.recorded_winner_changes, 3u) << "face, obj, obj, face, obj";
}

TEST(WhatIf_test, WithoutTheInhibitionTheFaceWinsTheTiesItLost) {
    HandRecording recording;
    const auto port = read(recording.path);
    WhatIfOptions options;
    options.carriers["/obj/out"] = object_without_inhibition;
    const auto result = run(port, options);
    // Both active at 0.20, 0.30, 0.40 and 1.45 with equal outputs: the earliest connection, the
    // face, wins each time.
    EXPECT_EQ(result.changed, 4u);
    EXPECT_EQ(decision_of(result, "/obj/out", 3).what_if, "priority");
    EXPECT_EQ(decision_of(result, "/obj/out", 1).what_if, "priority");
    EXPECT_EQ(decision_of(result, "/face/out", 2).what_if, "delivered");
    EXPECT_EQ(decision_of(result, "/obj/out", 2).what_if, "priority");
    EXPECT_FALSE(decision_of(result, "/face/out", 3).changed());
    EXPECT_EQ(result.sources[0].what_if_delivered, 3u);
    EXPECT_TRUE(result.sources[1].replaced);
    const std::string svg = timeline_svg(port, result, "what-if");
    EXPECT_EQ(svg.rfind("<svg", 0), 0u);
    EXPECT_NE(svg.find("<circle"), std::string::npos) << "changed messages are ringed";
}

TEST(WhatIf_test, ADecisionTheUnrecordedPastMadeIsLeftToTheWarmUpNotCountedAsChanged) {
    test::TempDir dir;
    const std::string path = dir.file("late.mcap");
    RecordingWriter writer(path, port_name);
    writer.connection("/face/out", face_carrier, 0);
    writer.connection("/obj/out", object_carrier, 1);
    LivePort live(port_name, {{"/face/out", face_carrier}, {"/obj/out", object_carrier}}, dir.file(""));
    // The object was seen just before the recording began: live, it still inhibits the face.
    live.decide("/obj/out", 1, cbor(1), started_clock - 0.1, started_clock - 0.1);
    const double face_at = started_clock + 0.1;
    writer.message("/face/out", 1, face_at, cbor(1));
    writer.decision("/face/out", 1, live.decide("/face/out", 1, cbor(1), face_at, face_at), face_at, face_at);
    const double later = started_clock + 1.0;  // past tc: the past is forgotten
    writer.message("/face/out", 2, later, cbor(2));
    writer.decision("/face/out", 2, live.decide("/face/out", 2, cbor(2), later, later), later, later);
    writer.close();

    const auto result = run(read(path));
    EXPECT_EQ(decision_of(result, "/face/out", 1).recorded, "priority");
    EXPECT_EQ(decision_of(result, "/face/out", 1).standing, Standing::warm_up);
    EXPECT_EQ(result.warm_up, 1u);
    EXPECT_EQ(result.compared, 1u);
    EXPECT_EQ(result.changed, 0u);
}

TEST(WhatIf_test, ErrorsNameWhatIsWrong) {
    HandRecording recording;
    const auto port = read(recording.path);
    WhatIfOptions unknown;
    unknown.carriers["/nobody/out"] = face_carrier;
    auto result = what_if(port, unknown);
    ASSERT_FALSE(result.ok());
    EXPECT_NE(result.error().message.find("no connection from /nobody/out"), std::string::npos);

    WhatIfOptions bad;
    bad.carriers["/obj/out"] = "local+recv.priority+tc.fast";
    result = what_if(port, bad);
    ASSERT_FALSE(result.ok());
    EXPECT_NE(result.error().message.find("tc.fast"), std::string::npos) << result.error().message;

    WhatIfOptions missing;
    missing.carriers["/obj/out"] = "local+recv.portmonitor+type.lua+file.nowhere";
    result = what_if(port, missing);
    ASSERT_FALSE(result.ok());
    EXPECT_NE(result.error().message.find("nowhere"), std::string::npos) << result.error().message;

    auto reader = mcap::Reader::open(recording.path);
    ASSERT_TRUE(reader.ok());
    auto other = read_recorded_port(*reader, "/not/recorded");
    ASSERT_FALSE(other.ok());
    EXPECT_NE(other.error().message.find("/gaze/in"), std::string::npos) << "it says which ports there are";
}

TEST(WhatIf_test, ATruncatedRecordingIsRefusedWithTheOffset) {
    HandRecording recording;
    std::ifstream in(recording.path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string cut = recording.dir.file("cut.mcap");
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    auto reader = mcap::Reader::open(cut);
    if (reader.ok()) {
        auto port = read_recorded_port(*reader, port_name);
        ASSERT_FALSE(port.ok());
        EXPECT_NE(port.error().message.find("offset"), std::string::npos) << port.error().message;
    } else {
        EXPECT_NE(reader.error().message.find("offset"), std::string::npos) << reader.error().message;
    }
}

// A Lua monitor on a third connection: it drops invalid cues and cues PortMonitor.now() says are
// not due yet, sets e_cue for 0.3 s while a cue is seen (the face is delivered only while it
// holds), sets e_quiet, and puts a constraint on its own connection.
const std::string cue_script = R"(
PortMonitor.accept = function(msg)
    return msg.data.valid and PortMonitor.now() >= msg.data.not_before
end
PortMonitor.update = function(msg)
    if msg.data.seen then PortMonitor.setEvent("e_cue", 0.3) else PortMonitor.unsetEvent("e_cue") end
    if msg.data.quiet then PortMonitor.setEvent("e_quiet") else PortMonitor.unsetEvent("e_quiet") end
    PortMonitor.setConstraint("not e_quiet")
    return msg
end
)";
const std::string cue_carrier = "local+recv.portmonitor+type.lua+file.cue";
const std::string cued_face_carrier = "local+recv.portmonitor+constraint.e_cue+recv.priority+tc.0.5";

struct Sent {
    std::string source;
    std::uint64_t seq;
    double at;  ///< seconds from the start
    proto::Bytes payload;
};

/// 20 s of three sources: faces at 30 Hz, an object at 10 Hz while it is in view, cues at 5 Hz.
std::vector<Sent> twenty_seconds() {
    std::mt19937 random(28);
    std::uniform_real_distribution<double> unit(0, 1);
    std::vector<Sent> sent;
    std::uint64_t face = 0, object = 0, cue = 0;
    for (double t = 0.013; t < 20; t += 1.0 / 30)
        sent.push_back({"/face/out", ++face, t + 0.002 * unit(random), cbor({{"x", face}})});
    for (double t = 0.051; t < 20; t += 0.1) {
        if ((t > 3 && t < 7) || (t > 12 && t < 15))
            sent.push_back({"/obj/out", ++object, t + 0.002 * unit(random), cbor({{"x", object}})});
    }
    for (double t = 0.077; t < 20; t += 0.2) {
        const double unix_at = static_cast<double>(test::started_unix_ns) / 1e9 + t;
        const nlohmann::json cue_data{{"valid", unit(random) < 0.9},
                                      {"seen", unit(random) < 0.6},
                                      {"quiet", unit(random) < 0.2},
                                      {"not_before", unit(random) < 0.1 ? unix_at + 1.0 : unix_at - 1.0}};
        sent.push_back({"/cue/out", ++cue, t, cbor(cue_data)});
    }
    std::stable_sort(sent.begin(), sent.end(), [](const Sent& a, const Sent& b) { return a.at < b.at; });
    // The test's live run takes each message whole; the daemon (and the re-run) would let another
    // message in between a cue's monitors and its arbitration. None does here.
    for (std::size_t i = 0; i + 1 < sent.size(); ++i) {
        if (sent[i].source == "/cue/out") {
            EXPECT_GT(sent[i + 1].at, sent[i].at + 0.0001) << "a message within a cue's monitor time";
        }
    }
    return sent;
}

/// The monitors begin at the message's time and the arbitration decides this much later.
constexpr double monitor_cost = 0.00003;

std::vector<std::string> live_outcomes(const std::vector<Sent>& sent,
                                       const std::vector<LivePort::Connection>& carriers,
                                       const std::string& script_dir) {
    LivePort live(port_name, carriers, script_dir);
    std::vector<std::string> outcomes;
    for (const auto& m : sent) {
        const double t = started_clock + m.at;
        const double decided = m.source == "/cue/out" ? t + monitor_cost : t;
        outcomes.push_back(live.decide(m.source, m.seq, m.payload, t, decided));
    }
    return outcomes;
}

TEST(WhatIf_test, AMonitorsEventsAndConstraintsComeOutAsRecordedAndAWeightChangesAKnownCount) {
    test::TempDir dir;
    dir.write("cue.lua", cue_script);
    const std::string path = dir.file("cued.mcap");
    const std::vector<LivePort::Connection> recorded_carriers{
        {"/face/out", cued_face_carrier}, {"/obj/out", object_carrier}, {"/cue/out", cue_carrier}};
    const auto sent = twenty_seconds();
    const auto outcomes = live_outcomes(sent, recorded_carriers, dir.file(""));
    {
        RecordingWriter writer(path, port_name);
        for (std::size_t i = 0; i < recorded_carriers.size(); ++i)
            writer.connection(recorded_carriers[i].source, recorded_carriers[i].carrier, i);
        for (std::size_t i = 0; i < sent.size(); ++i) {
            const double t = started_clock + sent[i].at;
            writer.message(sent[i].source, sent[i].seq, t, sent[i].payload);
            const double decided = sent[i].source == "/cue/out" ? t + monitor_cost : t;
            writer.decision(sent[i].source, sent[i].seq, outcomes[i], t, decided);
        }
        writer.close();
    }
    // Every outcome occurs, or the test proves less than it says.
    for (const char* outcome : {"delivered", "accept", "constraint", "priority"})
        EXPECT_NE(std::count(outcomes.begin(), outcomes.end(), outcome), 0) << outcome;

    const auto port = read(path);
    WhatIfOptions options;
    options.script_dirs = {dir.file("")};
    const auto same = run(port, options);
    EXPECT_EQ(same.changed, 0u);
    EXPECT_EQ(same.undecided, 0u);
    // The live run began from an empty past, as the re-run does: nothing is left to the warm-up.
    EXPECT_EQ(same.warm_up, 0u);
    EXPECT_EQ(same.compared, sent.size());
    EXPECT_EQ(same.script_errors, 0u);

    // The object no longer inhibits the face: the test's own live run with that weight says which
    // messages go the other way.
    options.carriers["/obj/out"] = object_without_inhibition;
    const auto changed = run(port, options);
    auto what_if_carriers = recorded_carriers;
    what_if_carriers[1].carrier = object_without_inhibition;
    const auto expected_outcomes = live_outcomes(sent, what_if_carriers, dir.file(""));
    std::uint64_t expected = 0;
    for (std::size_t i = 0; i < sent.size(); ++i) {
        ASSERT_EQ(changed.decisions[i].seq, sent[i].seq);
        EXPECT_EQ(changed.decisions[i].what_if, expected_outcomes[i])
            << sent[i].source << " seq " << sent[i].seq;
        if (changed.decisions[i].standing == Standing::compared && expected_outcomes[i] != outcomes[i])
            ++expected;
    }
    EXPECT_GT(expected, 10u);
    EXPECT_EQ(changed.changed, expected);
}

}  // namespace
}  // namespace plexus::record
