// Hostile peers that pass the hello and then lie inside data frames or attach what is not theirs.
// (tests/integration/hostile/hostile_peer.hpp has the raw peers and shared expectations.)
#include "hostile_peer.hpp"

namespace plexus::test::hostile {
namespace links_test {

// ---------------------------------------------------------------------------------------------
// A peer that passes the hello and then lies inside a data frame

// Fails until the daemon is fixed: Session::on_data hands the record of a link session (role "link",
// after "attach") to the port without decode_record, so a record whose fields do not decode is
// delivered to the reader (whose read() throws "bad message record") instead of the link getting an
// error frame and a close, as PROTOCOL.md requires for "any frame whose fields do not decode".
TEST(Hostile_test, ALinkThatSendsABrokenRecordIsCutOffAndTheReaderIsUnharmed) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client good({daemon.socket()});
    auto sink = good.open("/victim/sink");
    auto source = good.open("/victim/source");
    ASSERT_EQ(good.connect("/victim/source", "/victim/sink"), "local");
    auto hostile = Stream::tcp(daemon.address());
    // On loopback without a secret a node name is only claimed: the link claims the source's
    // node, so its attach passes (see the next test for one that does not).
    ASSERT_TRUE(hostile.send(concat(proto::encode_hello({proto::protocol_version, "link", "solo"}),
                                    request_frame(1, {{"op", "attach"},
                                                      {"source", "/victim/source"},
                                                      {"destination", "/victim/sink"},
                                                      {"carrier", "tcp"}}))));
    auto attached = hostile.reply_to(1);
    ASSERT_TRUE(attached.has_value());
    ASSERT_EQ(attached->code, proto::ReplyCode::ok) << attached->body.dump();
    // A record whose source declares 200 bytes of which 3 follow: its fields do not decode.
    Bytes broken;
    proto::append_data_frame(broken, 0, Bytes{0xc8, 0x01, '/', 'e', 'v'});

    ASSERT_TRUE(hostile.send(broken));
    const auto frames = hostile.frames_until_closed();
    source.write(Value("fine"));
    std::optional<Received> first;
    EXPECT_NO_THROW(first = sink.read(5s)) << "the broken record reached the reader";

    EXPECT_EQ(hostile.end(), End::eof) << "hostile link " << end_name(hostile.end());
    EXPECT_TRUE(error_reason(frames).has_value()) << "no error frame for a record that does not decode";
    if (!first)
        first = sink.read(5s);  // the read that threw left the good message queued
    ASSERT_TRUE(first.has_value());
    EXPECT_EQ(first->data, Value("fine"));
    EXPECT_EQ(first->envelope.source, "/victim/source");
    EXPECT_TRUE(daemon.process().running());
}

TEST(Hostile_test, ALinkMayNotAttachASourceOfAnotherNode) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client good({daemon.socket()});
    auto sink = good.open("/victim/sink");
    auto source = good.open("/victim/source");
    for (const std::string forged : {"/victim/source", "/not/registered"}) {
        auto hostile = Stream::tcp(daemon.address());
        ASSERT_TRUE(
            hostile.send(concat(hello_frame("link"), request_frame(1, {{"op", "attach"},
                                                                       {"source", forged},
                                                                       {"destination", "/victim/sink"},
                                                                       {"carrier", "tcp"}}))));
        auto attached = hostile.reply_to(1);
        ASSERT_TRUE(attached.has_value());
        EXPECT_EQ(attached->code, proto::ReplyCode::refused) << attached->body.dump();
        EXPECT_NE(attached->body.value("error", std::string{}).find(forged), std::string::npos)
            << attached->body.dump();
    }
    auto stats = good.stats("/victim/sink");
    EXPECT_TRUE(stats["ports"][0]["inbound"].empty()) << stats.dump();
}

/// A data_batch frame for `handle` holding one record per source, then `extra` raw bytes appended
/// to the records (and `count` declared: by default the number of sources).
Bytes batch_frame(std::uint64_t handle, const std::vector<std::string>& sources, const Bytes& extra = {},
                  std::optional<std::uint64_t> count = std::nullopt) {
    Bytes records;
    std::uint64_t seq = 1;
    for (const auto& source : sources) {
        Bytes payload;
        nlohmann::json::to_cbor(Value("from " + source), payload);
        proto::append_batch_record(records, source, seq++, 1, payload);
    }
    records.insert(records.end(), extra.begin(), extra.end());
    Bytes frame;
    proto::append_batch_frame_prefix(frame, handle, count.value_or(sources.size()), records.size());
    frame.insert(frame.end(), records.begin(), records.end());
    return frame;
}

TEST(Hostile_test, ABrokenBatchIsRefusedWholeAndTheReaderSeesNoneOfIt) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client good({daemon.socket()});
    auto sink = good.open("/batch/sink");
    using Make = std::function<Bytes(std::uint64_t handle)>;
    const std::vector<std::pair<std::string, Make>> broken_batches = {
        {"a record from another port",
         [](auto h) {
             return batch_frame(h, {"/batch/evil", "/batch/other"});
         }},
        {"fewer records than the count", [](auto h) { return batch_frame(h, {"/batch/evil"}, {}, 3); }},
        {"a record length past the end",
         [](auto h) {
             return batch_frame(h, {"/batch/evil"}, {0x7f, 0x01});
         }},
        {"bytes after the last record", [](auto h) { return batch_frame(h, {"/batch/evil"}, {0x00}); }},
        {"a count of zero", [](auto h) { return batch_frame(h, {}, {}, 0); }},
    };
    for (const auto& [what, make] : broken_batches) {
        SCOPED_TRACE(what);
        auto hostile = Stream::open(daemon, Listener::daemon_unix);
        const auto opened = open_raw_port(hostile, "/batch/evil");
        ASSERT_TRUE(opened.has_value());
        const auto handle = *opened;
        ASSERT_EQ(good.connect("/batch/evil", "/batch/sink"), "local");
        ASSERT_TRUE(hostile.send(make(handle)));
        const auto frames = hostile.frames_until_closed();
        EXPECT_EQ(hostile.end(), End::eof) << end_name(hostile.end());
        EXPECT_TRUE(error_reason(frames).has_value()) << "no error frame for " << what;
        // The port goes with its session; then nothing from the batch may be queued for the reader.
        ASSERT_TRUE(eventually([&] { return !good.lookup("/batch/evil").has_value(); }));
        EXPECT_FALSE(sink.read(std::chrono::milliseconds(0)).has_value()) << "part of a broken batch arrived";
    }
    EXPECT_TRUE(daemon.process().running());
}

}  // namespace links_test
}  // namespace plexus::test::hostile
