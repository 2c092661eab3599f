// Hostile peers that connect and never complete their handshake: cut off on every stream listener
// (daemon TCP and Unix socket, name server TCP) once the handshake timeout has passed, and counted.
// Otherwise each such peer holds a socket and a session for good, and enough of them exhaust the
// daemon's descriptors.
// (tests/integration/hostile/hostile_peer.hpp has the raw peers and shared expectations.)
#include "hostile_peer.hpp"
#include "plexus/proto/auth.hpp"
#include "tls_peer.hpp"

namespace plexus::test::hostile {
namespace handshake_test {

/// A daemon with an embedded name server whose handshake timeout (the name server's too) is 300 ms.
std::vector<std::string> with_handshake_timeout(const TempDir& dir) {
    const std::string config = dir.file("handshake.json");
    std::ofstream(config) << R"({"handshake_timeout_ms": 300})";
    return {"--config", config};
}

TEST(Hostile_test, APeerThatSaysNothingOrHalfAHelloIsCutOffOnEveryStreamListener) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", with_handshake_timeout(dir));
    const Bytes half_hello = [] {
        const Bytes hello = hello_frame("client");
        return Bytes(hello.begin(), hello.begin() + 3);  // a frame that never completes
    }();
    for (const auto listener : stream_listeners) {
        for (const bool partial : {false, true}) {
            auto stream = Stream::open(daemon, listener);
            const auto connected = Clock::now();
            if (partial) {
                ASSERT_TRUE(stream.send(half_hello));
            }
            stream.frames_until_closed(connected + slower(10s));  // the listener's own hello, at most
            EXPECT_EQ(stream.end(), End::eof)
                << listener_name(listener) << (partial ? ", half a hello: " : ", silent: ")
                << end_name(stream.end());
            EXPECT_GE(Clock::now() - connected, 300ms)
                << listener_name(listener) << ": cut off before its time";
        }
    }
    // Counted: four on the daemon's listeners; the name server's in its log.
    nlohmann::json stats;
    ASSERT_TRUE(eventually([&] {
        stats = nlohmann::json::parse(run_cli(dir, daemon, {"stats", "--json"}).out);
        return stats["daemon"]["handshake_timeouts"] == 4;
    })) << stats.dump();
    const auto log = daemon.process().err() + daemon.process().out();
    EXPECT_NE(log.find("no hello within 300 ms of connecting: cut off"), std::string::npos) << log;
    // Peers that do say hello in time are served as ever.
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, AStandaloneNameServerCutsOffAPeerThatSaysNothing) {
    TempDir dir;
    NameServerProcess names(dir, {"--handshake-timeout-ms", "300"});
    auto stream = Stream::tcp(names.address());
    stream.frames_until_closed(Clock::now() + slower(10s));
    EXPECT_EQ(stream.end(), End::eof) << end_name(stream.end());
    // A daemon registering through it is served as ever.
    Daemon daemon(dir, "solo", names.address());
    EXPECT_EQ(run_cli(dir, daemon, {"list"}).status, 0);
    const auto log = names.process().err() + names.process().out();
    EXPECT_NE(log.find("no hello within 300 ms of connecting: cut off"), std::string::npos) << log;
}

/// A daemon whose limits per peer are small enough to reach in a test.
std::vector<std::string> with_peer_limits(const TempDir& dir, const std::string& limits,
                                          std::vector<std::string> more = {}) {
    const std::string config = dir.file("peers.json");
    std::ofstream(config) << limits;
    more.insert(more.begin(), {"--config", config});
    return more;
}

/// True when the daemon closed `stream` without a word: not even its hello (a refused peer).
bool closed_at_once(Stream& stream) {
    const auto frames = stream.frames_until_closed(Clock::now() + slower(5s));
    return stream.end() == End::eof && frames.empty();
}

std::uint64_t peers_refused(const TempDir& dir, const Daemon& daemon) {
    const auto stats = nlohmann::json::parse(run_cli(dir, daemon, {"stats", "--json"}).out);
    return stats["daemon"]["peers_refused"].get<std::uint64_t>();
}

/// True when the daemon greeted `stream` with its hello: the connection was admitted.
bool greeted(Stream& stream) {
    const auto frame = stream.next_frame(Clock::now() + slower(5s));
    return frame && frame->type == FrameType::hello;
}

TEST(Hostile_test, APeerBeyondItsHandshakesInFlightIsRefusedAtOnceAndOthersAreServed) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", with_peer_limits(dir, R"({"peer_handshakes": 2})"));
    // Two silent TCP connections from 127.0.0.1 hold its two handshakes; the third is closed unheard.
    auto first = Stream::open(daemon, Listener::daemon_tcp);
    auto second = Stream::open(daemon, Listener::daemon_tcp);
    ASSERT_TRUE(greeted(first) && greeted(second));
    auto third = Stream::open(daemon, Listener::daemon_tcp);
    EXPECT_TRUE(closed_at_once(third)) << end_name(third.end());
    EXPECT_EQ(peers_refused(dir, daemon), 1u);
    // A local client is another peer (by its uid): served meanwhile.
    EXPECT_TRUE(still_answers(daemon, Listener::daemon_unix));
    // Once the silent ones go, the address is admitted again.
    first.close();
    second.close();
    EXPECT_TRUE(eventually([&] {
        auto again = Stream::open(daemon, Listener::daemon_tcp);
        return greeted(again);
    })) << "the address stayed refused after its connections closed";
    expect_everyone_still_served(daemon);
    const auto log = daemon.process().out() + daemon.process().err();
    EXPECT_NE(log.find("refused a connection from address 127.0.0.1: it has 2 connections not through their "
                       "handshake (peer_handshakes)"),
              std::string::npos)
        << log;
}

TEST(Hostile_test, TheNameServerRefusesAPeerBeyondItsHandshakesInFlightAndCountsIt) {
    TempDir dir;
    NameServerProcess names(dir, {"--peer-handshakes", "2"});
    auto first = Stream::tcp(names.address());
    auto second = Stream::tcp(names.address());
    ASSERT_TRUE(greeted(first) && greeted(second));
    auto third = Stream::tcp(names.address());
    EXPECT_TRUE(closed_at_once(third)) << end_name(third.end());
    // Counted in its ping (asked over UDP: loopback, no secret).
    auto ping = [&]() -> nlohmann::json {
        Datagrams udp(names.address());
        auto answer = udp.exchange(request_frame(7, {{"op", "ping"}}));
        if (!answer || answer->type != FrameType::reply)
            return {};
        auto reply = proto::decode_reply(answer->fields);
        return reply ? reply->body : nlohmann::json{};
    };
    EXPECT_EQ(ping().value("peers_refused", std::uint64_t{99}), 1u) << ping().dump();
    // Once the silent ones go, the address is admitted again: a daemon registers through it.
    first.close();
    second.close();
    EXPECT_TRUE(eventually([&] {
        auto again = Stream::tcp(names.address());
        return greeted(again);
    })) << "the address stayed refused after its connections closed";
    Daemon daemon(dir, "solo", names.address());
    EXPECT_EQ(run_cli(dir, daemon, {"list"}).status, 0);
    const auto log = names.process().out() + names.process().err();
    EXPECT_NE(log.find("names: refused a connection from address 127.0.0.1: it has 2 connections not through "
                       "their handshake (peer_handshakes)"),
              std::string::npos)
        << log;
}

TEST(Hostile_test, ALocalUserBeyondItsConnectionsIsRefusedUntilOneCloses) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", with_peer_limits(dir, R"({"peer_connections": 3, "peer_handshakes": 3})"));
    std::vector<Stream> held;
    for (int i = 0; i < 3; ++i) {
        held.push_back(Stream::open(daemon, Listener::daemon_unix));
        ASSERT_TRUE(held.back().send(hello_frame("client")));
    }
    auto fourth = Stream::open(daemon, Listener::daemon_unix);
    EXPECT_TRUE(closed_at_once(fourth)) << end_name(fourth.end());
    held.pop_back();  // closes one: a place is free again
    EXPECT_TRUE(eventually([&] { return run_cli(dir, daemon, {"stats", "--json"}).status == 0; }));
    EXPECT_GE(peers_refused(dir, daemon), 1u);
}

TEST(Hostile_test, APeerThatFailsTheSecretTooOftenIsShutOutAndCounted) {
    TempDir dir;
    Daemon daemon(
        dir, "solo", "",
        with_peer_limits(dir, R"({"peer_failed_proofs": 2})", {"--secret-file", test_secret_file()}));
    const auto wrong = proto::Secret::from_bytes("a guess at the deployment's secret");
    ASSERT_TRUE(static_cast<bool>(wrong));
    for (int attempt = 0; attempt < 2; ++attempt) {
        auto guesser = Stream::open(daemon, Listener::daemon_tcp);
        const std::string failed = tls_handshake_with(guesser.descriptor(), *wrong, slower(5s));
        EXPECT_FALSE(failed.empty()) << "a wrong key completed the TLS handshake, attempt " << attempt;
        // Nothing in clear follows a failed handshake: the daemon closes.
        EXPECT_TRUE(closes_within(guesser.descriptor(), slower(5s))) << attempt;
    }
    const auto log_so_far = daemon.process().out() + daemon.process().err();
    EXPECT_NE(log_so_far.find("the peer does not hold this deployment's secret"), std::string::npos)
        << log_so_far;
    auto third = Stream::open(daemon, Listener::daemon_tcp);
    EXPECT_TRUE(closed_at_once(third)) << "a third guess within the minute was heard";
    EXPECT_EQ(peers_refused(dir, daemon), 1u);
    const auto log = daemon.process().out() + daemon.process().err();
    EXPECT_NE(log.find("2 failed proofs of the secret in the last minute (peer_failed_proofs)"),
              std::string::npos)
        << log;
}

}  // namespace handshake_test
}  // namespace plexus::test::hostile
