// Hostile peers, requests that are malformed, or well-formed and wrong: refused, the session goes on where it
// can. (tests/integration/hostile/hostile_peer.hpp has the raw peers and shared expectations.)
#include "hostile_peer.hpp"

namespace plexus::test::hostile {
namespace requests_test {

// ---------------------------------------------------------------------------------------------
// Requests that are malformed, or well-formed and wrong

TEST(Hostile_test, RequestsThatAreNotRequestsGetAnErrorFrameAndAClose) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);

    for (const auto& [what, body] : malformed_request_bodies()) {
        for (auto listener : stream_listeners) {
            SCOPED_TRACE(listener_name(listener) + ": " + what);
            expect_error_then_close(daemon, listener,
                                    concat(hello_frame(role_for(listener)), raw_request(1, body)),
                                    {"bad request"});
        }
        SCOPED_TRACE(listener_name(Listener::names_udp) + ": " + what);
        expect_error_datagram(daemon, raw_request(1, body), {"bad request"});
    }

    expect_unharmed(daemon, rss_before);
}

/// Sends `body` as request 1 on a fresh session of `listener`, expects a refusal (non-zero code
/// with an "error"), then checks that the same session still answers request 2.
void expect_refusal_and_session_goes_on(const Daemon& daemon, Listener listener, const nlohmann::json& body) {
    SCOPED_TRACE(listener_name(listener) + ": " + body.dump());
    const nlohmann::json harmless =
        listener == Listener::names_tcp ? nlohmann::json{{"op", "ping"}} : nlohmann::json{{"op", "node"}};
    auto stream = Stream::open(daemon, listener);
    ASSERT_TRUE(stream.send(concat(hello_frame(role_for(listener)), request_frame(1, body))));

    auto refusal = stream.reply_to(1);

    ASSERT_TRUE(refusal.has_value()) << "no reply (connection " << end_name(stream.end()) << ")";
    EXPECT_NE(refusal->code, proto::ReplyCode::ok) << refusal->body.dump();
    EXPECT_TRUE(refusal->body.contains("error") && refusal->body["error"].is_string())
        << refusal->body.dump();
    ASSERT_TRUE(stream.send(request_frame(2, harmless)));
    auto next = stream.reply_to(2);
    ASSERT_TRUE(next.has_value()) << "the session stopped answering after the refusal";
    EXPECT_EQ(next->code, proto::ReplyCode::ok);
}

TEST(Hostile_test, AnUnknownOpIsRefusedAndTheSessionGoesOn) {
    TempDir dir;
    Daemon daemon(dir, "solo");

    for (auto listener : stream_listeners) {
        expect_refusal_and_session_goes_on(daemon, listener, {{"op", "frobnicate"}, {"port", "/x"}});
        expect_refusal_and_session_goes_on(daemon, listener, {{"op", ""}});
    }
    Datagrams udp(daemon.names());
    auto answer = udp.exchange(request_frame(1, {{"op", "frobnicate"}}));
    ASSERT_TRUE(answer.has_value());
    ASSERT_EQ(answer->type, FrameType::reply);
    auto reply = proto::decode_reply(answer->fields);
    ASSERT_TRUE(reply.ok());
    EXPECT_EQ(reply->code, proto::ReplyCode::usage);

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, DaemonRequestsWithWrongTypedFieldsAreRefused) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const std::vector<nlohmann::json> bodies{
        {{"op", "open"}, {"port", 42}},
        {{"op", "open"}, {"port", nlohmann::json::array({"/a"})}},
        {{"op", "open"}, {"port", "/typed/policy"}, {"policy", 7}},
        {{"op", "open"}, {"port", "/typed/capacity"}, {"capacity", "big"}},
        {{"op", "close"}, {"handle", "one"}},
        {{"op", "connect"}, {"source", 1}, {"destination", 2}},
        {{"op", "connect"}, {"source", "/a"}, {"destination", "/b"}, {"carrier", 3}},
        {{"op", "stats"}, {"port", "/nobody/here"}, {"forwarded", "yes"}},
        {{"op", "attach"}, {"destination", 9}},
    };

    for (auto listener : {Listener::daemon_unix, Listener::daemon_tcp}) {
        for (const auto& body : bodies)
            expect_refusal_and_session_goes_on(daemon, listener, body);
    }

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

/// Asks the name server `bodies` over TCP (each on its own session) and over UDP: each is refused.
void expect_name_server_refuses(const Daemon& daemon, const std::vector<nlohmann::json>& bodies) {
    for (const auto& body : bodies)
        expect_refusal_and_session_goes_on(daemon, Listener::names_tcp, body);
    Datagrams udp(daemon.names());
    for (const auto& body : bodies) {
        SCOPED_TRACE("UDP: " + body.dump());
        auto answer = udp.exchange(request_frame(1, body));
        ASSERT_TRUE(answer.has_value());
        ASSERT_EQ(answer->type, FrameType::reply);
        auto reply = proto::decode_reply(answer->fields);
        ASSERT_TRUE(reply.ok());
        EXPECT_NE(reply->code, proto::ReplyCode::ok);
    }
}

TEST(Hostile_test, NameServerRequestsWithWrongTypedPortFieldsAreRefused) {
    TempDir dir;
    Daemon daemon(dir, "solo");

    expect_name_server_refuses(daemon, {{{"op", "lookup"}, {"port", 42}},
                                        {{"op", "register_port"}, {"port", 42}},
                                        {{"op", "unregister_port"}, {"port", nlohmann::json::object()}},
                                        {{"op", "add_connection"}, {"source", 1}, {"destination", true}}});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

// Fails until the name server is fixed: NameServer::handle reads "persistent" / "forget" with
// nlohmann's value(key, false), which throws type_error for a non-bool; nothing in NameSession
// catches it, the read loop coroutine dies (co_spawn with asio::detached swallows the exception),
// and the session is left open forever with no reply: the client hangs and the daemon leaks the
// socket (CLOSE-WAIT after the client goes). Not skipped: the test is bounded (3 s per request)
// and uses its own daemon, so it harms no other test.
TEST(Hostile_test, NameServerRequestsWithWrongTypedFlagsAreRefused) {
    TempDir dir;
    Daemon daemon(dir, "solo");

    expect_name_server_refuses(
        daemon, {{{"op", "add_connection"}, {"source", "/a"}, {"destination", "/b"}, {"persistent", "yes"}},
                 {{"op", "remove_connection"}, {"source", "/a"}, {"destination", "/b"}, {"forget", 1}}});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

}  // namespace requests_test
}  // namespace plexus::test::hostile
