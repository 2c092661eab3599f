// Recordings of the gaze demo (docs/RECORDING.md): what `plexus record` keeps, read back by an
// independent MCAP reader; `plexus what-if` reproducing every recorded decision and predicting
// what other weights would have done; `plexus play` replaying the detectors into the same
// connections; a recording whose client dies; files that are not recordings.
#include <gtest/gtest.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "harness.hpp"
#include "plexus/recording.hpp"
#include "recordings.hpp"

namespace plexus::test {
namespace record_test {

std::string detector_path() {
    return PLEXUS_DETECTOR_PATH;
}
std::string source_dir() {
    return PLEXUS_SOURCE_DIR;
}

const std::string certainty = "recv.portmonitor+type.lua+file.certainty+threshold.0.5+lifetime.0.5";
const std::string face_carrier = "local+" + certainty + "+event.e_face_seen+recv.priority+tc.0.5";
const std::string object_carrier =
    "local+" + certainty + "+event.e_object_seen+recv.priority+tc.0.5+ex./demo/face/out:-1";

/// The demo of ./scripts/run: a face and an object detector, in and out of view, into /gaze/in,
/// where the object inhibits the face. The connections persist: they come back when a player
/// opens the detectors' ports again.
class GazeDemo {
public:
    explicit GazeDemo(const TempDir& dir)
        : dir_(dir), daemon_(dir, "gaze", "", {"--scripts", monitors_dir()}) {
        reader_ = start_cli(dir, daemon_, {"read", "/gaze/in", "--policy", "latest"}, "gaze");
        EXPECT_TRUE(wait_port(dir, daemon_, "/gaze/in"));
    }
    void start_detectors() {
        face_ = std::make_unique<Process>(
            std::vector<std::string>{detector_path(), "/demo/face/out", "--kind", "face", "--seen", "9",
                                     "--gone", "4", "--seed", "1"},
            daemon_.env(), dir_.file("face"));
        object_ = std::make_unique<Process>(
            std::vector<std::string>{detector_path(), "/demo/object/out", "--kind", "object", "--seen", "4",
                                     "--gone", "5", "--offset", "1", "--seed", "2"},
            daemon_.env(), dir_.file("object"));
        for (const char* port : {"/demo/face/out", "/demo/object/out"})
            ASSERT_TRUE(wait_port(dir_, daemon_, port)) << port;
    }
    void connect() {
        ASSERT_EQ(run_cli(dir_, daemon_, {"connect", "/demo/face/out", "/gaze/in", face_carrier, "--persist"})
                      .status,
                  0);
        ASSERT_EQ(
            run_cli(dir_, daemon_, {"connect", "/demo/object/out", "/gaze/in", object_carrier, "--persist"})
                .status,
            0);
    }
    void stop_detectors() {
        face_.reset();
        object_.reset();
    }
    Daemon& daemon() { return daemon_; }

private:
    const TempDir& dir_;
    Daemon daemon_;
    std::unique_ptr<Process> reader_;
    std::unique_ptr<Process> face_;
    std::unique_ptr<Process> object_;
};

/// `plexus record ARGS` for `seconds`, then its summary; fails the test if it did not exit 0.
CliResult record_for(const TempDir& dir, Daemon& daemon, std::vector<std::string> args, double seconds) {
    args.insert(args.begin(), "record");
    args.push_back("--duration");
    args.push_back(std::to_string(seconds));
    auto result =
        run_cli(dir, daemon, args, "", std::chrono::milliseconds(static_cast<long>(seconds * 1000)) + 60s);
    EXPECT_EQ(result.status, 0) << result.out << result.err;
    return result;
}

/// The last line of `text`.
std::string last_line(const std::string& text) {
    std::string trimmed = text;
    while (!trimmed.empty() && trimmed.back() == '\n')
        trimmed.pop_back();
    const auto newline = trimmed.rfind('\n');
    return newline == std::string::npos ? trimmed : trimmed.substr(newline + 1);
}

/// What the arbitration of /gaze/in decides for each recorded message, computed here from the
/// rules of DESIGN ("Arbitration by stimulation") and not with the daemon's library: st = 1, so a
/// connection is active (x = 1) for tc = 0.5 s after each message that passed its monitor; with
/// bias 1, an active connection's output is 1 plus the inhibition of the other active ones, and
/// the largest output wins (ties: the earlier connection, the face's). `object_inhibits_face`
/// is the weight ex./demo/face/out on the object's connection (-1 as recorded, 0 for the what-if).
std::vector<std::string> predicted(const std::vector<RecordedDecision>& recorded,
                                   double object_inhibits_face) {
    std::map<std::string, double> last;  // the last stimulation of each source
    std::vector<std::string> out;
    auto active = [&](const std::string& source, double t) {
        auto found = last.find(source);
        return found != last.end() && t - found->second <= 0.5;
    };
    for (const auto& d : recorded) {
        if (d.outcome == "accept") {
            out.push_back("accept");
            continue;
        }
        last[d.source] = d.decision_time;
        const double t = d.decision_time;
        const bool face = active("/demo/face/out", t);
        const bool object = active("/demo/object/out", t);
        // y_object = 1 (nothing acts on it); y_face = 1 + w * y_object when both are active.
        const double y_object = object ? 1.0 : 0.0;
        const double y_face = face ? 1.0 + (object ? object_inhibits_face * y_object : 0.0) : 0.0;
        std::string winner;
        if (y_face > 0 && y_face >= y_object)
            winner = "/demo/face/out";
        else if (y_object > 0)
            winner = "/demo/object/out";
        out.push_back(winner == d.source ? "delivered" : "priority");
    }
    return out;
}

TEST(Record_test, TheGazeDemoRecordedReadsBackByteIdenticalAndWhatIfReproducesAndPredictsItsDecisions) {
    TempDir dir;
    GazeDemo demo(dir);
    demo.start_detectors();
    demo.connect();
    const std::string file = dir.file("gaze.mcap");
    record_for(dir, demo.daemon(), {"/gaze/in", "-o", file}, 20);

    // --info: the port, both connections, the counts.
    auto info = run_cli(dir, demo.daemon(), {"record", "--info", file, "--json"});
    ASSERT_EQ(info.status, 0) << info.err;
    const auto summary = nlohmann::json::parse(info.out);
    EXPECT_EQ(summary["ports"], nlohmann::json::array({"/gaze/in"}));
    EXPECT_EQ(summary["connections"].size(), 2u);
    EXPECT_GT(summary["messages"].get<std::uint64_t>(), 300u) << "two detectors at 20 Hz for 20 s";
    EXPECT_EQ(summary["end"]["lost_messages"], "0");
    EXPECT_GT(summary["seconds"].get<double>(), 15.0);

    // The connections at the start, with their carriers, are in the recording's note.
    {
        auto reader = mcap::Reader::open(file);
        ASSERT_TRUE(reader.ok()) << reader.error().message;
        nlohmann::json at_start;
        for (const auto& note : reader->metadata()) {
            if (note.name == mcap::layout::recording_metadata)
                at_start = nlohmann::json::parse(note.values.at("connections"));
        }
        ASSERT_EQ(at_start.size(), 2u) << at_start.dump();
        std::map<std::string, std::string> carriers;
        for (const auto& c : at_start)
            carriers[c["source"]] = c["carrier"];
        EXPECT_EQ(carriers["/demo/face/out"], face_carrier);
        EXPECT_EQ(carriers["/demo/object/out"], object_carrier);
    }

    // An independent reader (Foxglove's @mcap/core) reads every message byte-identical.
    const auto recording = Recording::open(file);
    std::vector<std::string> ours;
    recording.for_each([&](const RecordedMessage& m) {
        ours.push_back(m.port + " " + m.source + " " + std::to_string(m.sequence) + " " +
                       std::to_string(m.arrived_ns) + " " + std::to_string(m.sent_ns) + " " +
                       sha256_hex(m.payload.data(), m.payload.size()));
        return true;
    });
    ASSERT_EQ(ours.size(), summary["messages"].get<std::uint64_t>());
    if (node_path().empty()) {
        ADD_FAILURE() << "no node: ./scripts/deps installs Debian's nodejs for this check";
    } else {
        Process node({node_path(), source_dir() + "/tests/mcap/read_mcap.js", file}, {}, dir.file("node"));
        ASSERT_EQ(node.wait(120s), 0) << node.err();
        std::vector<std::string> theirs;
        std::istringstream lines(node.out());
        for (std::string line; std::getline(lines, line);) {
            const auto m = nlohmann::json::parse(line);
            if (m["metadata"].value("plexus.kind", "") != "messages")
                continue;
            theirs.push_back(m["topic"].get<std::string>() + " " +
                             m["metadata"]["plexus.source"].get<std::string>() + " " +
                             std::to_string(m["sequence"].get<std::uint64_t>()) + " " +
                             m["logTime"].get<std::string>() + " " + m["publishTime"].get<std::string>() +
                             " " + m["sha256"].get<std::string>());
        }
        EXPECT_EQ(theirs, ours);
    }

    // The recorded decisions follow DESIGN's rules (the independent model agrees with them), but
    // for a few at the very start: the stimulation of messages before the recording began is not
    // in the file (the warm-up, docs/WHAT_IF.md), and the model starts from an empty past.
    const auto recorded = decisions_of(file, "/gaze/in");
    // A message still in its monitors when the recording stopped has no decision in the file.
    ASSERT_LE(recorded.size(), ours.size());
    EXPECT_LE(ours.size() - recorded.size(), 2u);
    const auto as_recorded = predicted(recorded, -1);
    std::vector<bool> warm_up(recorded.size(), false);
    std::size_t warm = 0;
    for (std::size_t i = 0; i < recorded.size(); ++i) {
        if (as_recorded[i] == recorded[i].outcome)
            continue;
        warm_up[i] = true;
        ++warm;
        EXPECT_LE(recorded[i].decision_time - recorded.front().decision_time, 0.5 + 1e-6)
            << "the model disagrees with the recording past tc of its start, at message " << i;
    }
    EXPECT_LE(warm, 3u);

    // ...what-if with the recorded carriers reproduces every one of them it compares (all but
    // those the unrecorded past decided)...
    auto same =
        run_cli(dir, demo.daemon(), {"what-if", file, "/gaze/in", "--scripts", monitors_dir(), "--json"});
    ASSERT_EQ(same.status, 0) << same.err;
    const auto same_totals = nlohmann::json::parse(last_line(same.out));
    // Both leave out warm-up messages their own model of the unknown past gets wrong: this test's
    // model (here) and the daemon's library re-run (what-if) may differ on a message or two of the
    // first tc (a boundary instant, two decisions in the same microsecond), never after it.
    const std::size_t what_if_compared = same_totals["messages"].get<std::size_t>();
    const std::size_t warm_difference = what_if_compared > recorded.size() - warm
                                            ? what_if_compared - (recorded.size() - warm)
                                            : recorded.size() - warm - what_if_compared;
    EXPECT_LE(warm_difference, 3u) << "what-if compared " << what_if_compared << " of " << recorded.size()
                                   << " messages; this test's model left out " << warm;
    EXPECT_EQ(same_totals["changed"], 0) << same.out;

    // ...and without the object's inhibition it reports the messages that change hands, as many
    // as the independent computation finds.
    const auto without = predicted(recorded, 0);
    std::size_t expected_changes = 0;
    for (std::size_t i = 0; i < recorded.size(); ++i)
        expected_changes += !warm_up[i] && without[i] != recorded[i].outcome ? 1 : 0;
    EXPECT_GT(expected_changes, 0u)
        << "the demo's detectors overlap in view: some messages must change hands";
    const std::string no_inhibition =
        "local+" + certainty + "+event.e_object_seen+recv.priority+tc.0.5+ex./demo/face/out:0";
    auto changed = run_cli(dir, demo.daemon(),
                           {"what-if", file, "/gaze/in", "--scripts", monitors_dir(), "--carrier",
                            "/demo/object/out=" + no_inhibition, "--json"});
    ASSERT_EQ(changed.status, 0) << changed.err;
    const auto totals = nlohmann::json::parse(last_line(changed.out));
    // Exactly, but for the warm-up messages one side compared and the other left out (above).
    const auto reported = totals["changed"].get<std::size_t>();
    EXPECT_LE(reported > expected_changes ? reported - expected_changes : expected_changes - reported,
              warm_difference)
        << changed.out << "\nthis test's model expects " << expected_changes << " changes";
    std::cout << "what-if without inhibition: " << totals.dump() << '\n';

    // The SVG timeline is written.
    auto svg = run_cli(dir, demo.daemon(),
                       {"what-if", file, "/gaze/in", "--scripts", monitors_dir(), "--carrier",
                        "/demo/object/out=" + no_inhibition, "--svg", dir.file("timeline.svg")});
    EXPECT_EQ(svg.status, 0) << svg.err;
    EXPECT_TRUE(std::filesystem::file_size(dir.file("timeline.svg")) > 1000);

    // Replayed into the same connections, the detectors' streams win and lose as recorded, but for
    // the few messages whose timing moved across a boundary of tc.
    demo.stop_detectors();
    const std::string replayed = dir.file("replayed.mcap");
    auto recorder = start_cli(dir, demo.daemon(), {"record", "/gaze/in", "-o", replayed}, "rerecord");
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(replayed); }));
    auto play = run_cli(dir, demo.daemon(), {"play", file}, "", 120s);
    ASSERT_EQ(play.status, 0) << play.err;
    recorder->signal(SIGINT);
    ASSERT_EQ(recorder->wait(60s), 0) << recorder->err();
    const auto again = decisions_of(replayed, "/gaze/in");
    // The k-th message of each source in one recording against the k-th in the other.
    std::map<std::string, std::vector<std::string>> before;
    std::map<std::string, std::vector<std::string>> after;
    for (const auto& d : recorded)
        before[d.source].push_back(d.outcome);
    for (const auto& d : again)
        after[d.source].push_back(d.outcome);
    std::size_t compared = 0;
    std::size_t differing = 0;
    for (const auto& [source, outcomes] : before) {
        const auto& replay = after[source];
        EXPECT_EQ(replay.size(), outcomes.size()) << source << ": every recorded message played once";
        for (std::size_t i = 0; i < std::min(replay.size(), outcomes.size()); ++i) {
            ++compared;
            differing += replay[i] != outcomes[i] ? 1 : 0;
        }
    }
    std::cout << "replay: " << differing << " of " << compared << " decisions differ from the recording\n";
    // Accept decisions depend on the payloads only; arbitration ones on timing within tc: a few
    // messages sit within the scheduling jitter of a boundary (docs/RECORDING.md, "Replaying").
    EXPECT_LE(differing * 20, compared) << "more than 5% of the replayed decisions differ";
}

/// `plexus write /w` into `plexus read /r`, with /r being recorded by `plexus record` into FILE.
struct RecordedPipe {
    RecordedPipe(const TempDir& dir, const std::string& node)
        : daemon(dir, node), writer(dir, daemon, "/w", "writer"), file(dir.file(node + ".mcap")) {
        EXPECT_TRUE(wait_port(dir, daemon, "/w"));
        reader = start_cli(dir, daemon, {"read", "/r", "/w"}, "reader");
        EXPECT_TRUE(wait_port(dir, daemon, "/r")) << reader->err();
        recorder = start_cli(dir, daemon, {"record", "/r", "-o", file}, "recorder");
        EXPECT_TRUE(eventually([&] { return std::filesystem::exists(file); })) << recorder->err();
    }
    Daemon daemon;
    CliWriter writer;
    std::unique_ptr<Process> reader;
    std::string file;
    std::unique_ptr<Process> recorder;
};

TEST(Record_test, ARecordingWhoseClientIsKilledIsClosedValidByTheDaemon) {
    TempDir dir;
    RecordedPipe pipe(dir, "orphan");
    auto& [daemon, writer, reader, file, recorder] = pipe;
    writer.send("1\n2\n3\n");
    recorder->signal(SIGKILL);
    recorder->wait(10s);
    // The daemon notices its client is gone and closes the file: it then has its end note.
    ASSERT_TRUE(eventually([&] {
        try {
            return !Recording::open(file).end_note().empty();
        } catch (const std::exception&) {
            return false;
        }
    }));
    EXPECT_EQ(Recording::open(file).end_note()["reason"], "its client went away");
}

TEST(Record_test, AFileThatIsNotARecordingIsAClearErrorNamingTheOffsetNeverACrash) {
    TempDir dir;
    RecordedPipe pipe(dir, "bad");
    auto& [daemon, writer, reader, file, recorder] = pipe;
    for (int i = 0; i < 50; ++i)
        writer.send("{\"n\": " + std::to_string(i) + "}\n");
    ASSERT_TRUE(eventually([&] {
        const std::string lines = reader->out();
        return std::count(lines.begin(), lines.end(), '\n') >= 50;
    }));
    recorder->signal(SIGINT);
    ASSERT_EQ(recorder->wait(30s), 0) << recorder->err();
    writer.finish();  // play opens /w again
    std::string bytes;
    {
        std::ifstream in(file, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    ASSERT_GT(bytes.size(), 200u);
    const auto write_file = [&](const std::string& name, const std::string& content) {
        std::ofstream(dir.file(name), std::ios::binary) << content;
        return dir.file(name);
    };
    const std::vector<std::string> broken{
        write_file("truncated.mcap", bytes.substr(0, bytes.size() / 2)),
        write_file("garbage.mcap", std::string(4096, 'x')),
        write_file("empty.mcap", ""),
        write_file("flipped.mcap",
                   [&] {
                       std::string copy = bytes;
                       copy[copy.size() / 3] ^= 0x5a;
                       return copy;
                   }()),
    };
    for (const auto& path : broken) {
        for (const auto& args : std::vector<std::vector<std::string>>{
                 {"record", "--info", path}, {"play", path}, {"what-if", path, "/r"}}) {
            auto result = run_cli(dir, daemon, args);
            const std::string what = args[0] + " " + path;
            EXPECT_TRUE(result.status == 2 || result.status == 4)
                << what << ": " << result.status << result.err;
            EXPECT_LT(result.status, 128) << what << " crashed";
            EXPECT_NE(result.err.find("offset"), std::string::npos) << what << ": " << result.err;
        }
    }
}

TEST(Record_test, PortsOnTwoNodesAreRecordedEachByItsOwnDaemonIntoAFileWithTheClockNote) {
    TempDir dir;
    Daemon a(dir, "a");
    Daemon b(dir, "b", a.names());
    CliWriter to_a(dir, a, "/a/w", "writer-a");
    CliWriter to_b(dir, b, "/b/w", "writer-b");
    ASSERT_TRUE(wait_port(dir, a, "/a/w"));
    ASSERT_TRUE(wait_port(dir, b, "/b/w"));
    auto read_a = start_cli(dir, a, {"read", "/a/in", "/a/w"}, "reader-a");
    auto read_b = start_cli(dir, b, {"read", "/b/in", "/b/w"}, "reader-b");
    ASSERT_TRUE(wait_port(dir, a, "/a/in")) << read_a->err();
    ASSERT_TRUE(wait_port(dir, a, "/b/in")) << read_b->err();
    // Asked of node a's daemon, for a port of each node.
    const std::string file = dir.file("both.mcap");
    const std::string file_b = dir.file("both.b.mcap");
    auto recorder = start_cli(dir, a, {"record", "/a/in", "/b/in", "-o", file}, "recorder");
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(file) && std::filesystem::exists(file_b); }))
        << recorder->err();
    to_a.send("1\n2\n3\n");
    to_b.send("4\n5\n");
    const auto lines_of = [](const Process& process) {
        const std::string out = process.out();
        return std::count(out.begin(), out.end(), '\n');
    };
    ASSERT_TRUE(eventually([&] { return lines_of(*read_a) >= 3 && lines_of(*read_b) >= 2; }));
    recorder->signal(SIGINT);
    ASSERT_EQ(recorder->wait(30s), 0) << recorder->err();
    const auto recording_a = Recording::open(file);
    const auto recording_b = Recording::open(file_b);
    EXPECT_EQ(recording_a.node(), "a");
    EXPECT_EQ(recording_b.node(), "b");
    EXPECT_EQ(recording_a.ports(), std::vector<std::string>{"/a/in"});
    EXPECT_EQ(recording_b.ports(), std::vector<std::string>{"/b/in"});
    EXPECT_EQ(recording_a.message_count(), 3u);
    EXPECT_EQ(recording_b.message_count(), 2u);
    // The clock note lines the files up: wall-clock arrival times on both.
    for (const auto* recording : {&recording_a, &recording_b}) {
        recording->for_each([](const RecordedMessage& m) {
            EXPECT_GT(m.arrived_ns, 1'600'000'000'000'000'000ull) << "ns since the Unix epoch";
            return true;
        });
    }
}

TEST(Record_test, ARecordingOnAnotherNodeEndsWhenItsClientStopsAsking) {
    TempDir dir;
    Daemon a(dir, "a");
    Daemon b(dir, "b", a.names());
    auto read_b = start_cli(dir, b, {"read", "/b/in"}, "reader-b");
    ASSERT_TRUE(wait_port(dir, a, "/b/in")) << read_b->err();
    const std::string file_b = dir.file("lease.b.mcap");
    auto recorder = start_cli(dir, a, {"record", "/b/in", "-o", dir.file("lease.mcap")}, "recorder");
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(file_b); })) << recorder->err();
    recorder->signal(SIGKILL);
    recorder->wait(10s);
    // Node b's daemon closes its file once nobody asked about it for its lease (5 s).
    ASSERT_TRUE(eventually(
        [&] {
            try {
                return !Recording::open(file_b).end_note().empty();
            } catch (const std::exception&) {
                return false;
            }
        },
        30s));
    EXPECT_EQ(Recording::open(file_b).end_note()["reason"], "its client went away");
}

}  // namespace record_test
}  // namespace plexus::test
