// Hostile peers, all at once: after every attack the daemon serves old and new clients.
// (tests/integration/hostile/hostile_peer.hpp has the raw peers and shared expectations.)
#include "hostile_peer.hpp"

namespace plexus::test::hostile {
namespace everything_test {

// ---------------------------------------------------------------------------------------------
// Everyone else

/// Every attack above, once, on every listener.
void attack_everything(const Daemon& daemon) {
    std::mt19937 random(7);
    std::vector<Bytes> attacks;
    for (auto length : lying_lengths) {
        attacks.push_back(lying_header(length));
        attacks.push_back(concat(hello_frame("client"), lying_header(length)));
    }
    for (std::size_t size : {1, 100, 60000})
        attacks.push_back(random_bytes(size, random));
    const Bytes whole = request_frame(1, {{"op", "ping"}});
    attacks.push_back(concat(hello_frame("client"), Bytes(whole.begin(), whole.begin() + 3)));
    attacks.push_back(raw_hello("HTTP", 1, role_and_node("client")));
    attacks.push_back(raw_hello("PLXS", 99, role_and_node("client")));
    for (const auto& [what, body] : malformed_request_bodies()) {
        attacks.push_back(concat(hello_frame("client"), raw_request(1, body)));
    }

    // Bounded as a whole: a daemon that hung on every connection fails the test, in seconds.
    const auto deadline = Clock::now() + 15s;
    for (const auto& attack : attacks) {
        for (auto listener : stream_listeners) {
            auto stream = Stream::open(daemon, listener);
            stream.send(attack, deadline);
            stream.shutdown_write();
            stream.frames_until_closed(std::min(deadline, Clock::now() + exchange_timeout));
            EXPECT_NE(stream.end(), End::timeout)
                << listener_name(listener) << " kept a hostile connection open";
        }
        Datagrams udp(daemon.names());
        udp.send(ByteView(attack).first(std::min<std::size_t>(attack.size(), 65507)));
        EXPECT_TRUE(udp.receive(std::min(deadline, Clock::now() + exchange_timeout)).has_value())
            << "no answer over UDP";
    }
}

TEST(Hostile_test, AfterTheAttackTheDaemonStillServesOldAndNewClients) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client before({daemon.socket()});
    auto held = before.open("/before/held");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);

    attack_everything(daemon);

    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    ASSERT_TRUE(daemon.process().running()) << daemon.process().err();
    // The client that was connected before the attack opens ports, connects and reads its data.
    auto sink = before.open("/before/sink");
    auto source = before.open("/before/source");
    EXPECT_EQ(before.connect("/before/source", "/before/sink"), "local");
    source.write(Value{{"after", "attack"}});
    auto message = sink.read(5s);
    ASSERT_TRUE(message.has_value());
    EXPECT_EQ(message->data, (Value{{"after", "attack"}}));
    // New clients: the CLI writes and reads through the daemon, and lists through the name server.
    auto reader =
        start_cli(dir, daemon, {"read", "/after/sink", "--count", "1", "--timeout", "10"}, "reader");
    ASSERT_TRUE(wait_port(dir, daemon, "/after/sink"));
    auto written = run_cli(dir, daemon, {"write", "/after/source", "/after/sink"}, "42\n");
    EXPECT_EQ(written.status, 0) << written.err;
    ASSERT_EQ(reader->wait(10s), 0) << reader->err();
    EXPECT_EQ(reader->out(), "42\n");
    auto listed = run_cli(dir, daemon, {"list"});
    EXPECT_EQ(listed.status, 0) << listed.err;
    EXPECT_NE(listed.out.find("/before/held"), std::string::npos) << listed.out;
    auto names_list = Client::ask_names(daemon.names(), {{"op", "list"}});
    ASSERT_TRUE(names_list.has_value());
    EXPECT_NE(names_list->dump().find("/before/sink"), std::string::npos) << names_list->dump();
    expect_everyone_still_served(daemon);
    EXPECT_TRUE(daemon.process().running());
}

}  // namespace everything_test
}  // namespace plexus::test::hostile
