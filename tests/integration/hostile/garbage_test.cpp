// Hostile peers, random bytes, truncated frames and wrong hellos on every listener.
// (tests/integration/hostile/hostile_peer.hpp has the raw peers and shared expectations.)
#include "hostile_peer.hpp"

namespace plexus::test::hostile {
namespace garbage_test {

// ---------------------------------------------------------------------------------------------
// Random bytes and truncated frames

TEST(Hostile_test, RandomBytesCloseTheConnectionOnEveryStreamListener) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    std::mt19937 random(20240602);
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);

    for (auto listener : stream_listeners) {
        for (std::size_t size : {std::size_t{1}, std::size_t{100}, std::size_t{64 * 1024}}) {
            for (bool after_hello : {false, true}) {
                SCOPED_TRACE(listener_name(listener) + ", " + std::to_string(size) + " random bytes" +
                             (after_hello ? " after a hello" : ""));
                auto stream = Stream::open(daemon, listener);
                const Bytes noise = random_bytes(size, random);

                if (after_hello)
                    stream.send(hello_frame(role_for(listener)));
                stream.send(noise);
                stream.shutdown_write();  // a frame the noise began can now never be finished
                const auto frames = stream.frames_until_closed();

                EXPECT_TRUE(stream.end() == End::eof || stream.end() == End::reset)
                    << "connection " << end_name(stream.end());
                if (auto reason = error_reason(frames)) {
                    EXPECT_FALSE(reason->empty());
                }
            }
        }
    }

    expect_unharmed(daemon, rss_before);
}

TEST(Hostile_test, RandomDatagramsGetAnErrorDatagram) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    std::mt19937 random(20240602);

    for (std::size_t size : {std::size_t{1}, std::size_t{100}, std::size_t{65507}}) {
        SCOPED_TRACE(std::to_string(size) + " random bytes");
        expect_error_datagram(daemon, random_bytes(size, random), {});
    }
    // An empty datagram too.
    expect_error_datagram(daemon, {}, {});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, ATruncatedFrameFollowedByACloseHarmsNobody) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const Bytes whole = request_frame(1, {{"op", "ping"}, {"port", "/some/port/name/long/enough"}});
    const Bytes half(whole.begin(), whole.begin() + static_cast<std::ptrdiff_t>(whole.size() / 2));

    for (auto listener : stream_listeners) {
        SCOPED_TRACE(listener_name(listener));
        {
            auto stream = Stream::open(daemon, listener);
            ASSERT_TRUE(stream.send(concat(hello_frame(role_for(listener)), half)));
            stream.close();  // gone without a word
        }
        {
            // Half-closed instead: the peer sees the end inside a frame and closes its side too.
            auto stream = Stream::open(daemon, listener);
            ASSERT_TRUE(stream.send(concat(hello_frame(role_for(listener)), half)));
            stream.shutdown_write();
            stream.frames_until_closed();
            EXPECT_EQ(stream.end(), End::eof) << "connection " << end_name(stream.end());
        }
        {
            // A hello cut short, then the end.
            const Bytes hello = hello_frame(role_for(listener));
            auto stream = Stream::open(daemon, listener);
            ASSERT_TRUE(stream.send(ByteView(hello).first(hello.size() - 3)));
            stream.shutdown_write();
            stream.frames_until_closed();
            EXPECT_EQ(stream.end(), End::eof) << "connection " << end_name(stream.end());
        }
    }
    expect_error_datagram(daemon, half, {});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

// ---------------------------------------------------------------------------------------------
// Hellos that are wrong

TEST(Hostile_test, AHelloWithTheWrongMagicIsRefusedNamingTheMagic) {
    TempDir dir;
    Daemon daemon(dir, "solo");

    for (auto listener : stream_listeners) {
        SCOPED_TRACE(listener_name(listener));
        expect_error_then_close(daemon, listener, raw_hello("HTTP", 1, role_and_node(role_for(listener))),
                                {"magic"});
        expect_error_then_close(daemon, listener, raw_hello("PLX", 1, {}), {});  // too short for the magic
    }
    expect_error_datagram(daemon, raw_hello("HTTP", 1, role_and_node("cli")), {});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, AHelloOfAnotherVersionIsRefusedNamingBothVersions) {
    TempDir dir;
    Daemon daemon(dir, "solo");

    for (auto listener : stream_listeners) {
        SCOPED_TRACE(listener_name(listener));
        expect_error_then_close(daemon, listener, raw_hello("PLXS", 99, role_and_node(role_for(listener))),
                                {"version", "99", std::to_string(proto::protocol_version)});
        // A later version may lay out the rest differently: still answered with the version mismatch.
        expect_error_then_close(daemon, listener,
                                raw_hello("PLXS", proto::protocol_version + 1, {0xff, 0xff, 0xff}),
                                {"version", std::to_string(proto::protocol_version + 1)});
        // Versions are u32: a larger one is refused.
        expect_error_then_close(daemon, listener,
                                raw_hello("PLXS", std::uint64_t{1} << 40, role_and_node("client")),
                                {"version"});
        // A request before any hello.
        expect_error_then_close(daemon, listener, request_frame(1, {{"op", "ping"}}), {"hello"});
    }
    for (auto listener : {Listener::daemon_tcp, Listener::daemon_unix}) {
        SCOPED_TRACE(listener_name(listener));
        expect_error_then_close(daemon, listener, hello_frame("admin"), {"admin"});
        expect_error_then_close(daemon, listener, hello_frame(std::string(65, 'r')),
                                {"role"});  // over 64 bytes
    }
    expect_error_datagram(daemon, raw_hello("PLXS", 99, role_and_node("cli")), {});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

}  // namespace garbage_test
}  // namespace plexus::test::hostile
