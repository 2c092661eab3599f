// Hostile peers that connect and never complete their handshake: cut off on every stream listener
// (daemon TCP and Unix socket, name server TCP) once the handshake timeout has passed, and counted.
// Otherwise each such peer holds a socket and a session for good, and enough of them exhaust the
// daemon's descriptors.
// (tests/integration/hostile/hostile_peer.hpp has the raw peers and shared expectations.)
#include "hostile_peer.hpp"

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

}  // namespace handshake_test
}  // namespace plexus::test::hostile
