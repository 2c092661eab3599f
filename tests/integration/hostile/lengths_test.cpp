// Hostile peers, lengths that lie: refused at the header, no memory spent on what they declare.
// (tests/integration/hostile/hostile_peer.hpp has the raw peers and shared expectations.)
#include "hostile_peer.hpp"

namespace plexus::test::hostile {
namespace lengths_test {

// ---------------------------------------------------------------------------------------------
// Lengths that lie

TEST(Hostile_test, LengthsOverTheLimitAreRefusedAtOnceOnEveryStreamListener) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);

    for (auto listener : stream_listeners) {
        for (auto length : lying_lengths) {
            for (bool after_hello : {false, true}) {
                SCOPED_TRACE(listener_name(listener) + ", declared length " + std::to_string(length) +
                             (after_hello ? ", after a hello" : ", as the first bytes"));
                // Only the header is sent and the connection is kept open: the length alone must be
                // refused, before any body arrives.
                const Bytes attack = after_hello
                                         ? concat(hello_frame(role_for(listener)), lying_header(length))
                                         : lying_header(length);
                expect_error_then_close(daemon, listener, attack, {"exceeds limit", std::to_string(length)});
            }
        }
    }

    expect_unharmed(daemon, rss_before);
}

TEST(Hostile_test, ARequestOverOneMebibyteIsRefusedAtItsHeaderWhileDataMayBeLarger) {
    // A request body decodes to up to 16 times its size: 1 MiB is the limit, judged from the header.
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);
    for (auto listener : {Listener::daemon_tcp, Listener::daemon_unix}) {
        SCOPED_TRACE(listener_name(listener));
        const std::uint64_t length = proto::max_request_frame + 1;
        expect_error_then_close(daemon, listener, concat(hello_frame("client"), lying_header(length)),
                                {"request frame length", "exceeds limit 1048576"});
    }
    expect_unharmed(daemon, rss_before);
}

TEST(Hostile_test, APeerThatSendsRequestsButNeverReadsTheRepliesIsHeldBack) {
    // Without a bound the daemon would read every request and keep every reply for a peer that
    // never reads: memory without limit. It stops reading such a peer once replies pile up.
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);
    auto stream = Stream::open(daemon, Listener::daemon_unix);
    ASSERT_TRUE(stream.send(hello_frame("client")));
    Bytes block;
    for (std::uint64_t id = 1; id <= 1000; ++id) {
        const Bytes request = request_frame(id, {{"op", "stats"}});
        block.insert(block.end(), request.begin(), request.end());
    }
    int blocks_sent = 0;
    while (blocks_sent < 500 && stream.send(block, Clock::now() + std::chrono::seconds(2)))
        ++blocks_sent;
    EXPECT_LT(blocks_sent, 500) << "the daemon kept reading 500,000 requests whose replies nobody read";
    expect_unharmed(daemon, rss_before);
}

TEST(Hostile_test, LengthsOverTheLimitGetAnErrorDatagramFromTheNameServerUdpPort) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);

    for (auto length : lying_lengths) {
        SCOPED_TRACE("declared length " + std::to_string(length));
        expect_error_datagram(daemon, lying_header(length), {"exceeds limit", std::to_string(length)});
        // "After a hello": the name server's UDP port takes requests only, so a hello datagram is
        // refused by itself, and the lie that follows it on the same socket still is.
        Datagrams udp(daemon.names());
        auto hello_answer = udp.exchange(hello_frame("cli"));
        ASSERT_TRUE(hello_answer.has_value());
        EXPECT_EQ(hello_answer->type, FrameType::error);
        auto answer = udp.exchange(lying_header(length));
        ASSERT_TRUE(answer.has_value());
        ASSERT_EQ(answer->type, FrameType::error);
        auto reason = proto::decode_error(answer->fields);
        ASSERT_TRUE(reason.ok());
        EXPECT_NE(reason->find("exceeds limit"), std::string::npos) << *reason;
        // And both in one datagram: still one error datagram.
        expect_error_datagram(daemon, concat(hello_frame("cli"), lying_header(length)), {});
    }

    expect_unharmed(daemon, rss_before);
}

TEST(Hostile_test, LengthsJustUnderTheLimitDoNotCostTheirSizeInMemoryWhileNoBodyArrives) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);
    std::vector<Stream> open_streams;

    // Four sessions each promise a 64 MiB data frame (allowed) and send only its first bytes.
    for (auto listener :
         {Listener::daemon_tcp, Listener::daemon_unix, Listener::daemon_tcp, Listener::daemon_unix}) {
        auto stream = Stream::open(daemon, listener);
        ASSERT_TRUE(
            stream.send(concat(hello_frame("client"),
                               concat(lying_header(proto::default_max_frame, FrameType::data), {0, 1, 2}))));
        open_streams.push_back(std::move(stream));
    }
    ASSERT_TRUE(still_answers(daemon, Listener::daemon_unix));  // the daemon has read what they sent

    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    open_streams.clear();
    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

}  // namespace lengths_test
}  // namespace plexus::test::hostile
