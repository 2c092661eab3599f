// Hostile peers of shared memory: frames that lie, readers that never release, writers that never read.
// (tests/integration/hostile/hostile_peer.hpp has the raw peers and shared expectations.)
#include "hostile_peer.hpp"

namespace plexus::test::hostile {
namespace shm_test {

// ---------------------------------------------------------------------------------------------
// Shared memory

/// A data_shm frame for `handle` naming a place and a record head from `source`.
Bytes shm_frame(std::uint64_t handle, const proto::ShmPlace& place, const std::string& source) {
    Bytes rest;
    proto::append_shm_place(rest, place, source, 1, 1);
    Bytes frame;
    proto::append_shm_frame_prefix(frame, handle, rest.size());
    frame.insert(frame.end(), rest.begin(), rest.end());
    return frame;
}

TEST(Hostile_test, SharedMemoryFramesThatLieAreRefusedAndOthersAreUnharmed) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client good({daemon.socket()});
    auto sink = good.open("/shm/sink");
    struct Lie {
        std::string what;
        bool with_region;
        std::function<Bytes(std::uint64_t handle, std::uint64_t region, std::uint64_t size)> make;
        std::string reason;
    };
    const std::vector<Lie> lies = {
        {"data_shm without a region", false,
         [](auto h, auto, auto) {
             return shm_frame(h, {1, 0, 10}, "/shm/evil");
         },
         "not the region of handle"},
        {"data_shm naming a region that is not its own", true,
         [](auto h, auto region, auto) {
             return shm_frame(h, {region + 1000, 0, 10}, "/shm/evil");
         },
         "not the region of handle"},
        {"a place running past the region's end", true,
         [](auto h, auto region, auto size) {
             return shm_frame(h, {region, size - 5, 10}, "/shm/evil");
         },
         "outside its region"},
        {"an offset near 2^64", true,
         [](auto h, auto region, auto) {
             return shm_frame(h, {region, ~std::uint64_t{0} - 3, 10}, "/shm/evil");
         },
         "outside its region"},
        {"a record head from another port", true,
         [](auto h, auto region, auto) {
             return shm_frame(h, {region, 0, 10}, "/shm/sink");
         },
         "message from port"},
        {"a release of messages never sent", false,
         [](auto, auto, auto) { return proto::make_shm_number_frame(FrameType::shm_release, 1); },
         "shm_release of 1 messages, but 0 were sent"},
        {"a daemon's own shm_free frame", false,
         [](auto, auto, auto) { return proto::make_shm_free_frame(1, 0); }, "unexpected shm_free frame"},
    };
    for (const auto& lie : lies) {
        SCOPED_TRACE(lie.what);
        auto hostile = Stream::open(daemon, Listener::daemon_unix);
        const auto opened = open_raw_port(hostile, "/shm/evil");
        ASSERT_TRUE(opened.has_value());
        const auto handle = *opened;
        ASSERT_EQ(good.connect("/shm/evil", "/shm/sink"), "local");
        std::uint64_t region = 0;
        std::uint64_t size = 0;
        if (lie.with_region) {
            ASSERT_TRUE(hostile.send(request_frame(2, {{"op", "shm"}, {"handle", handle}})));
            auto given = hostile.reply_to(2);
            ASSERT_TRUE(given.has_value());
            ASSERT_EQ(given->code, proto::ReplyCode::ok) << given->body.dump();
            region = given->body["region"].get<std::uint64_t>();
            size = given->body["size"].get<std::uint64_t>();
        }
        ASSERT_TRUE(hostile.send(lie.make(handle, region, size)));
        const auto frames = hostile.frames_until_closed();
        EXPECT_EQ(hostile.end(), End::eof) << end_name(hostile.end());
        hostile.close();  // else the daemon keeps the session (and its port) for its 2 s of grace
        const auto reason = error_reason(frames);
        ASSERT_TRUE(reason.has_value()) << "no error frame";
        EXPECT_NE(reason->find(lie.reason), std::string::npos) << *reason;
        ASSERT_TRUE(eventually([&] { return !good.lookup("/shm/evil").has_value(); }));
        EXPECT_FALSE(sink.read(std::chrono::milliseconds(0)).has_value()) << "a lie reached the reader";
    }
    EXPECT_TRUE(daemon.process().running());
    EXPECT_EQ(good.stats()["daemon"]["shm_regions"], 0) << "a region outlived the session that lied";
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, AReaderThatNeverReleasesSharedMemoryIsCutOffAndTheSlotsComeBack) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client good({daemon.socket()});
    // The reader maps regions, reads every frame and never releases one.
    auto reader = Stream::open(daemon, Listener::daemon_unix);
    ASSERT_TRUE(reader.send(
        concat(hello_frame("client"), concat(request_frame(1, {{"op", "shm"}}),
                                             request_frame(2, {{"op", "open"}, {"port", "/lent/sink"}})))));
    ASSERT_TRUE(reader.reply_to(2).has_value());
    // The writer names the same slot again and again: the daemon does not track the writer's use of
    // its own region, so only the reader's bound stops the references piling up.
    auto writer = Stream::open(daemon, Listener::daemon_unix);
    const auto opened = open_raw_port(writer, "/lent/source");
    ASSERT_TRUE(opened.has_value());
    const auto handle = *opened;
    ASSERT_EQ(good.connect("/lent/source", "/lent/sink"), "local");
    ASSERT_TRUE(writer.send(request_frame(2, {{"op", "shm"}, {"handle", handle}})));
    auto given = writer.reply_to(2);
    ASSERT_TRUE(given.has_value());
    const auto region = given->body["region"].get<std::uint64_t>();

    std::thread reading([&] { reader.frames_until_closed(Clock::now() + 120s); });
    const Bytes one = shm_frame(handle, {region, 0, 10}, "/lent/source");
    Bytes many;
    for (int i = 0; i < 4096; ++i)
        many.insert(many.end(), one.begin(), one.end());
    // One message more than the daemon lets a reader hold (Outbox::max_lent, 2^18), and no more:
    // cutting the reader off frees every slot reference at once, and each free is a frame for
    // the writer, which never reads them, so the daemon stops reading this writer (as it must:
    // Session::frees_pile_up). Messages sent after the cut would wait for its 60 s deadline.
    const std::size_t rounds = (std::size_t{1} << 18) / 4096;
    bool sent = true;
    for (std::size_t i = 0; sent && i < rounds; ++i)
        sent = writer.send(many, Clock::now() + 60s);
    sent = sent && writer.send(one, Clock::now() + 60s);
    reading.join();
    EXPECT_TRUE(sent) << "the daemon stopped reading the writer before the reader was cut off";

    EXPECT_NE(reader.end(), End::timeout) << "the reader holding every slot reference was not cut off";
    writer.close();
    EXPECT_TRUE(eventually([&] { return good.stats()["daemon"]["shm_slots"] == 0; }))
        << "slot references outlived the reader that held them";
    EXPECT_TRUE(daemon.process().running());
}

TEST(Hostile_test, AMalformedShmRequestLeavesNoHalfMadeRegionBehind) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    auto hostile = Stream::open(daemon, Listener::daemon_unix);
    const auto opened = open_raw_port(hostile, "/half/evil");
    ASSERT_TRUE(opened.has_value());
    const auto handle = *opened;
    ASSERT_TRUE(hostile.send(request_frame(2, {{"op", "shm"}, {"handle", handle}, {"bytes", "many"}})));
    auto refused = hostile.reply_to(2);
    ASSERT_TRUE(refused.has_value());
    EXPECT_NE(refused->code, proto::ReplyCode::ok);

    ASSERT_TRUE(hostile.send(shm_frame(handle, {1, 0, 10}, "/half/evil")));
    const auto reason = error_reason(hostile.frames_until_closed());

    ASSERT_TRUE(reason.has_value());
    EXPECT_NE(reason->find("not the region of handle"), std::string::npos) << *reason;
    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, APayloadInSharedMemoryLargerThanAFrameIsRefused) {
    TempDir dir;
    const auto config = dir.file("plexusd.json");
    std::ofstream(config) << R"({"max_frame": 1048576})";
    Daemon daemon(dir, "solo", "", {"--config", config});
    auto hostile = Stream::open(daemon, Listener::daemon_unix);
    const auto opened = open_raw_port(hostile, "/big/evil");
    ASSERT_TRUE(opened.has_value());
    const auto handle = *opened;
    ASSERT_TRUE(hostile.send(request_frame(2, {{"op", "shm"}, {"handle", handle}, {"bytes", 1048576}})));
    auto given = hostile.reply_to(2);
    ASSERT_TRUE(given.has_value());
    ASSERT_EQ(given->code, proto::ReplyCode::ok);
    EXPECT_GE(given->body["size"].get<std::uint64_t>(), 4u * 1048576u);

    ASSERT_TRUE(hostile.send(shm_frame(handle, {given->body["region"], 0, 2 * 1048576}, "/big/evil")));
    const auto reason = error_reason(hostile.frames_until_closed());

    ASSERT_TRUE(reason.has_value());
    EXPECT_NE(reason->find("exceeds the frame limit"), std::string::npos) << *reason;
}

TEST(Hostile_test, AWriterThatNeverReadsItsFreesIsHeldBack) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    auto writer = Stream::open(daemon, Listener::daemon_unix);
    const auto opened = open_raw_port(writer, "/frees/evil");
    ASSERT_TRUE(opened.has_value());
    const auto handle = *opened;
    ASSERT_TRUE(writer.send(request_frame(2, {{"op", "shm"}, {"handle", handle}})));
    auto given = writer.reply_to(2);
    ASSERT_TRUE(given.has_value());
    const Bytes one = shm_frame(handle, {given->body["region"], 0, 10}, "/frees/evil");
    Bytes many;
    for (int i = 0; i < 4096; ++i)
        many.insert(many.end(), one.begin(), one.end());

    // Each message goes to nobody and is done with at once: a shm_free frame for the writer, who
    // never reads. Unbounded, 1,000 rounds would queue four million of them in the daemon.
    int rounds = 0;
    while (rounds < 1000 && writer.send(many, Clock::now() + 2s))
        ++rounds;

    EXPECT_LT(rounds, 1000) << "the daemon kept reading a writer that leaves its frees unread";
    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, SharedMemoryIsOnlyForClientsOnTheUnixSocket) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    auto remote = Stream::open(daemon, Listener::daemon_tcp);
    ASSERT_TRUE(remote.send(concat(hello_frame("client"), request_frame(1, {{"op", "shm"}}))));
    auto reply = remote.reply_to(1);
    ASSERT_TRUE(reply.has_value());
    EXPECT_EQ(reply->code, proto::ReplyCode::refused);
    EXPECT_NE(reply->body.value("error", std::string()).find("Unix socket"), std::string::npos)
        << reply->body.dump();
}

}  // namespace shm_test
}  // namespace plexus::test::hostile
