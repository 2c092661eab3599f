// Hostile peers of the shared-memory rings (PROTOCOL.md, "Rings"): a local client holds a region
// it can write at any time, positions and flags included. Whatever it writes, it must not crash
// the daemon nor reach another client's memory; a well-behaved libplexus client on the same
// daemon keeps working after every attack. rings_wake_test.cpp has the peers that try to stall
// it; ring_peer.hpp the raw ring client, ring_checks.hpp what the two files share.
#include <random>

#include "ring_checks.hpp"

namespace plexus::test::hostile {
namespace rings_test {

// ---------------------------------------------------------------------------------------------
// The protocol as documented

TEST(HostileRings_test, ARawRingClientOpensPortsAndMessagesGoBothWaysThroughTheRings) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    RingPeer peer(daemon);

    ASSERT_TRUE(peer.start());
    EXPECT_EQ(peer.ring_bytes(), proto::RingLayout::default_ring_bytes);
    const auto inbox = open_through_rings(peer, 1, "/ring/in");
    const auto outbox = open_through_rings(peer, 2, "/ring/out");
    ASSERT_TRUE(inbox && outbox);

    // Daemon -> client: the good client writes into the raw peer's port.
    ASSERT_EQ(good.client().connect("/good/out", "/ring/in"), "local");
    ASSERT_TRUE(good.round_trip());
    bool delivered = false;
    const auto deadline = Clock::now() + exchange_timeout;
    while (!delivered) {
        const auto frame = peer.next_frame(deadline);
        ASSERT_TRUE(frame.has_value()) << "no data frame through the ring";
        for (const auto& [handle, bytes] : records_of(*frame)) {
            const auto record = proto::decode_record(bytes);
            ASSERT_TRUE(record.ok()) << record.error().message;
            EXPECT_EQ(handle, *inbox);
            EXPECT_EQ(record->source, "/good/out");
            const auto payload =
                nlohmann::json::from_cbor(record->payload.begin(), record->payload.end(), true, false);
            delivered = delivered || (payload.is_object() && payload.value("n", 0) == 1);
        }
    }

    // Client -> daemon: a data frame the raw peer writes into the ring reaches the good client.
    ASSERT_EQ(good.client().connect("/ring/out", "/good/in"), "local");
    Bytes record;
    proto::append_record(record, "/ring/out", 1, 0, cbor({{"from", "ring"}}));
    Bytes frame;
    proto::append_data_frame(frame, *outbox, record);
    ASSERT_TRUE(peer.send(frame));
    bool arrived = false;
    while (!arrived) {
        const auto message = good.in().read(exchange_timeout);
        ASSERT_TRUE(message.has_value()) << "the ring client's message never reached the good client";
        arrived = message->data.is_object() && message->data.value("from", "") == "ring";
        if (arrived) {
            EXPECT_EQ(message->envelope.source, "/ring/out");
        }
    }

    EXPECT_EQ(peer.socket_end(), End::open);
    const auto counters = daemon_counters(dir, daemon);
    EXPECT_EQ(counter(counters, "protocol_errors"), 0u) << counters.dump();
    EXPECT_GE(counter(counters, "ring_sessions"), 2u) << counters.dump();  // the good client's and ours
    EXPECT_EQ(counter(counters, "rings_refused"), 0u) << counters.dump();
}

// ---------------------------------------------------------------------------------------------
// Positions that lie

TEST(HostileRings_test, ATailClaimingMoreThanTheRingHoldsCutsTheSessionOff) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    struct Lie {
        std::string what;
        std::function<std::uint64_t(std::uint64_t tail, std::uint64_t ring)> tail;
    };
    const std::vector<Lie> lies = {
        {"one byte more than the ring holds", [](auto tail, auto ring) { return tail + ring + 1; }},
        {"a tail near 2^64", [](auto, auto) { return ~std::uint64_t{0} - 7; }},
        {"a tail behind what the daemon read", [](auto tail, auto) { return tail - 1; }},
    };

    for (const auto& lie : lies) {
        SCOPED_TRACE(lie.what);
        RingPeer peer(daemon);
        ASSERT_TRUE(peer.start());
        ASSERT_TRUE(open_through_rings(peer, 1, "/lie/tail"));

        peer.to_daemon_control().tail.store(lie.tail(peer.written(), peer.ring_bytes()),
                                            std::memory_order_release);
        peer.wake_daemon();

        expect_cut_off(peer, "more than the ring holds");
        EXPECT_TRUE(eventually([&] { return !good.client().lookup("/lie/tail").has_value(); }))
            << "the port outlived the session that lied";
    }
    expect_others_served(dir, daemon, good, lies.size(), lies.size() + 1);
}

TEST(HostileRings_test, AHeadClaimingMoreThanWasWrittenCutsTheSessionOffAtTheDaemonsNextWrite) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    struct Lie {
        std::string what;
        std::function<std::uint64_t(std::uint64_t tail, std::uint64_t ring)> head;
    };
    const std::vector<Lie> lies = {
        {"one byte more than was written", [](auto tail, auto) { return tail + 1; }},
        {"a head 2^63 ahead", [](auto tail, auto) { return tail + (std::uint64_t{1} << 63); }},
        {"a head more than a ring behind the tail", [](auto tail, auto ring) { return tail - ring - 1; }},
    };

    for (const auto& lie : lies) {
        SCOPED_TRACE(lie.what);
        RingPeer peer(daemon);
        ASSERT_TRUE(peer.start());
        ASSERT_TRUE(open_through_rings(peer, 1, "/lie/head"));  // read: head = tail now
        auto& control = peer.to_client_control();

        control.head.store(lie.head(control.tail.load(std::memory_order_acquire), peer.ring_bytes()),
                           std::memory_order_release);
        ASSERT_TRUE(peer.send(request_frame(2, {{"op", "node"}})));  // the daemon must write its reply

        EXPECT_EQ(peer.wait_for_socket_end(), End::eof) << "session " << end_name(peer.socket_end());
        EXPECT_TRUE(eventually([&] { return !good.client().lookup("/lie/head").has_value(); }))
            << "the port outlived the session that lied";
    }
    expect_others_served(dir, daemon, good, lies.size(), lies.size() + 1);
}

// ---------------------------------------------------------------------------------------------
// Bytes that are not frames, and frames that are not allowed

TEST(HostileRings_test, RandomBytesInTheRingGetAnErrorOrACloseAndHarmNobody) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    std::mt19937 random(20240602);
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);
    int sessions = 0;

    for (std::size_t size :
         {std::size_t{1}, std::size_t{100}, std::size_t{64 * 1024}, std::size_t{256 * 1024}}) {
        for (bool after_a_request : {false, true}) {
            SCOPED_TRACE(std::to_string(size) + " random bytes" +
                         (after_a_request ? " after a request" : ""));
            RingPeer peer(daemon);
            ASSERT_TRUE(peer.start());
            ++sessions;
            if (after_a_request) {
                ASSERT_TRUE(open_through_rings(peer, 1, "/garbage/" + std::to_string(sessions)));
            }

            // Not checked: the daemon may stop reading at the first bad byte, leaving no room.
            peer.send(random_bytes(size, random));
            peer.shutdown_socket_write();  // a frame the noise began can now never be finished
            const auto frames = peer.frames_until_closed();

            EXPECT_EQ(peer.wait_for_socket_end(), End::eof) << "session " << end_name(peer.socket_end());
            if (const auto reason = error_reason(frames)) {
                EXPECT_FALSE(reason->empty());
            }
        }
    }
    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    expect_others_served(dir, daemon, good, 0, sessions + 1);
}

TEST(HostileRings_test, BytesOnTheSocketAfterTheRingsRequestCutTheSessionOff) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    {
        SCOPED_TRACE("a request in the same write as the rings request");
        RingPeer peer(daemon);
        ASSERT_TRUE(peer.send_on_socket(concat(concat(hello_frame("client"), proto::make_rings_request(0)),
                                               request_frame(1, {{"op", "node"}}))));
        // The daemon read the request with the rings frame (refused before the switch, on the
        // socket), or after it (refused through the rings).
        const bool switched = peer.take_rings_answer(true);
        const auto frames = switched ? peer.frames_until_closed() : peer.socket_frames();
        EXPECT_EQ(peer.wait_for_socket_end(), End::eof) << "session " << end_name(peer.socket_end());
        const auto reason = error_reason(frames);
        ASSERT_TRUE(reason.has_value()) << "no error frame";
        EXPECT_NE(reason->find("on the socket after"), std::string::npos) << *reason;
    }
    for (const Bytes& late : {request_frame(1, {{"op", "node"}}), Bytes{0}}) {
        SCOPED_TRACE(std::to_string(late.size()) + " bytes on the socket after the answer");
        RingPeer peer(daemon);
        ASSERT_TRUE(peer.start());
        ASSERT_TRUE(peer.send_on_socket(late));
        expect_cut_off(peer, "on the socket after");
    }
    expect_others_served(dir, daemon, good, 3, 3);
}

TEST(HostileRings_test, ASecondRingsRequestCutsTheSessionOff) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    RingPeer peer(daemon);
    ASSERT_TRUE(peer.start());

    ASSERT_TRUE(peer.send(proto::make_rings_request(0)));

    expect_cut_off(peer, "rings asked for twice");
    expect_others_served(dir, daemon, good, 1, 2);
}

// ---------------------------------------------------------------------------------------------
// Bytes changed after they were published

TEST(HostileRings_test, ScribblingOverAPublishedFrameCrashesNothing) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    std::mt19937 random(31);
    const long rss_before = daemon.rss_kib();
    constexpr int rounds = 30;

    for (int round = 0; round < rounds; ++round) {
        SCOPED_TRACE("round " + std::to_string(round));
        RingPeer peer(daemon);
        ASSERT_TRUE(peer.start());
        const Bytes frame =
            request_frame(1, {{"op", "open"}, {"port", "/scribble/" + std::to_string(round)}});
        const std::size_t mask = peer.ring_bytes() - 1;
        const std::size_t at = peer.written() & mask;

        ASSERT_TRUE(peer.send(frame));
        // The daemon may copy the frame out before, during or after this: whatever it gets, it
        // decodes from its own copy.
        for (int pass = 0; pass < 200; ++pass) {
            for (std::size_t i = 0; i < frame.size(); ++i)
                peer.to_daemon_bytes()[(at + i) & mask] = static_cast<std::uint8_t>(random());
            if (round % 3 == 1) {  // the flags, and the daemon's own position it never reads back
                peer.to_daemon_control().reader_waiting.store(random());
                peer.to_daemon_control().writer_waiting.store(random());
                peer.to_daemon_control().head.store(random());
                peer.to_client_control().writer_waiting.store(random());
            }
            peer.wake_daemon();
        }
        peer.shutdown_socket_write();
        peer.frames_until_closed();
        EXPECT_EQ(peer.wait_for_socket_end(), End::eof) << "session " << end_name(peer.socket_end());
    }
    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    expect_others_served(dir, daemon, good, 0, rounds + 1);
}

// ---------------------------------------------------------------------------------------------
// Memory of one's own

TEST(HostileRings_test, EachClientGetsARegionOfItsOwnSealedAgainstResizing) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    RingPeer a(daemon);
    RingPeer b(daemon);
    ASSERT_TRUE(a.start());
    ASSERT_TRUE(b.start());

    struct stat of_a {};
    struct stat of_b {};
    ASSERT_EQ(::fstat(a.descriptor(proto::ring_region), &of_a), 0) << std::strerror(errno);
    ASSERT_EQ(::fstat(b.descriptor(proto::ring_region), &of_b), 0) << std::strerror(errno);
    EXPECT_NE(of_a.st_ino, of_b.st_ino) << "two clients were given the same memory";
    EXPECT_EQ(static_cast<std::size_t>(of_a.st_size), a.region_size());

    for (RingPeer* peer : {&a, &b}) {
        const int fd = peer->descriptor(proto::ring_region);
        const int seals = ::fcntl(fd, F_GET_SEALS);
        ASSERT_GE(seals, 0) << std::strerror(errno);
        EXPECT_EQ(seals & (F_SEAL_SHRINK | F_SEAL_GROW), F_SEAL_SHRINK | F_SEAL_GROW) << "seals " << seals;
        EXPECT_TRUE(seals & F_SEAL_SEAL) << "the client could unseal it: seals " << seals;
        EXPECT_NE(::ftruncate(fd, static_cast<off_t>(peer->region_size() / 2)), 0) << "the region shrank";
        EXPECT_NE(::ftruncate(fd, static_cast<off_t>(peer->region_size() * 2)), 0) << "the region grew";
        EXPECT_NE(::fcntl(fd, F_ADD_SEALS, F_SEAL_WRITE), 0) << "a seal was added after F_SEAL_SEAL";
    }

    // What A writes anywhere in its region is not in B's.
    std::memset(a.region() + proto::RingLayout::controls_size, 0xa5,
                a.region_size() - proto::RingLayout::controls_size);
    const std::uint8_t* seen = b.region() + proto::RingLayout::controls_size;
    EXPECT_EQ(std::count(seen, seen + (b.region_size() - proto::RingLayout::controls_size), 0xa5), 0);

    // B, untouched, still works; A's rings now hold only noise (whatever the daemon makes of it).
    a.wake_daemon();
    ASSERT_TRUE(open_through_rings(b, 1, "/own/b"));
    expect_others_served(dir, daemon, good, 0, 3);
}

}  // namespace rings_test
}  // namespace plexus::test::hostile
