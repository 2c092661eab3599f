// The request and reply structs of the control protocol: each round-trips through its body with the
// field names of PROTOCOL.md, and a field of the wrong type is refused with a reason, never thrown.
#include <gtest/gtest.h>

#include "plexus/proto/name_operations.hpp"
#include "plexus/proto/operations.hpp"

namespace plexus::proto {
namespace {

using nlohmann::json;

json document_of_inspect() {
    return {{"node", "n"}, {"address", "h:1"}, {"stats", json::object()}, {"arbitration", json::array()}};
}

/// Encodes `message`, decodes the body, encodes again: the two bodies must be the same.
template <class Message>
json round_trip(const Message& message) {
    const json body = message.encode();
    auto decoded = Message::decode(body);
    EXPECT_TRUE(decoded) << (decoded ? "" : decoded.error().message);
    if (!decoded)
        return body;
    EXPECT_EQ(decoded->encode(), body);
    return body;
}

/// A request body also names its op.
template <class Request>
json request_round_trip(const Request& request) {
    const json body = round_trip(request);
    EXPECT_EQ(body.value("op", ""), op_name(Request::op));
    return body;
}

/// `body` with `key` set to `value` is refused, and the reason names the key.
template <class Message>
void expect_refused(json body, const std::string& key, json value) {
    body[key] = std::move(value);
    SCOPED_TRACE(body.dump());
    Result<Message> decoded = Error{"not decoded"};
    EXPECT_NO_THROW(decoded = Message::decode(body));
    ASSERT_FALSE(decoded);
    EXPECT_NE(decoded.error().message.find("malformed"), std::string::npos) << decoded.error().message;
    EXPECT_NE(decoded.error().message.find("'" + key + "'"), std::string::npos) << decoded.error().message;
}

TEST(Operations_test, OpenRoundTripsWithItsWireNames) {
    OpenRequest open;
    open.port = "/a";
    open.policy = "latest";
    open.capacity = 8;
    const json body = request_round_trip(open);
    EXPECT_EQ(body, (json{{"op", "open"}, {"port", "/a"}, {"policy", "latest"}, {"capacity", 8}}));
    const auto decoded = OpenRequest::decode(body);
    ASSERT_TRUE(decoded);
    EXPECT_EQ(decoded->capacity, 8u);
    EXPECT_EQ(round_trip(OpenReply{3, "n"}), (json{{"handle", 3}, {"node", "n"}}));
}

TEST(Operations_test, MissingFieldsTakeTheirDefaults) {
    const auto open = OpenRequest::decode({{"op", "open"}, {"port", "/a"}});
    ASSERT_TRUE(open);
    EXPECT_EQ(open->policy, "strict");
    EXPECT_FALSE(open->capacity);
    const auto connect = ConnectRequest::decode({{"op", "connect"}});
    ASSERT_TRUE(connect);
    EXPECT_EQ(connect->carrier, "");
    EXPECT_FALSE(connect->strict);
    EXPECT_FALSE(connect->forwarded);
    const auto attached = AttachReply::decode(json::object());
    ASSERT_TRUE(attached);
    EXPECT_EQ(attached->policy, "strict");
    EXPECT_EQ(attached->capacity, 16u);
    EXPECT_FALSE(attached->udp_port);
}

TEST(Operations_test, EveryDaemonRequestRoundTrips) {
    request_round_trip(CloseRequest{7});
    EXPECT_EQ(request_round_trip(ShmRequest{}), (json{{"op", "shm"}}));
    EXPECT_EQ(request_round_trip(ShmRequest{5, 1000}), (json{{"op", "shm"}, {"handle", 5}, {"bytes", 1000}}));
    EXPECT_EQ(request_round_trip(ConnectRequest{"/a", "/b", "udp", true, true, false}),
              (json{{"op", "connect"},
                    {"source", "/a"},
                    {"destination", "/b"},
                    {"carrier", "udp"},
                    {"strict", true},
                    {"persist", true}}));
    EXPECT_EQ(
        request_round_trip(ConnectRequest{"/a", "/b", "", false, false, true}).value("forwarded", false),
        true);
    EXPECT_EQ(request_round_trip(DisconnectRequest{"/a", "/b", false}),
              (json{{"op", "disconnect"}, {"source", "/a"}, {"destination", "/b"}}));
    EXPECT_EQ(request_round_trip(AttachRequest{"/a", "/b", "mcast", false, "239.255.81.1:10102"})["group"],
              "239.255.81.1:10102");
    EXPECT_FALSE(request_round_trip(AttachRequest{"/a", "/b", "tcp", false, ""}).contains("group"));
    EXPECT_EQ(request_round_trip(StatsRequest{"", false}), (json{{"op", "stats"}, {"port", ""}}));
    EXPECT_EQ(request_round_trip(PingRequest{"/a", true}),
              (json{{"op", "ping"}, {"port", "/a"}, {"forwarded", true}}));
    EXPECT_EQ(request_round_trip(InspectRequest{true}), (json{{"op", "inspect"}, {"only", "arbitration"}}));
    EXPECT_EQ(request_round_trip(InspectRequest{false}), (json{{"op", "inspect"}}));
    EXPECT_EQ(request_round_trip(EventsRequest{"/a", true, false}),
              (json{{"op", "events"}, {"port", "/a"}, {"check", true}}));
    EXPECT_EQ(request_round_trip(NodeRequest{}), (json{{"op", "node"}}));

    ParamRequest param;
    param.source = "/a";
    param.destination = "/b";
    param.action = "set";
    param.values = {{"threshold", 0.5}};
    EXPECT_EQ(request_round_trip(param), (json{{"op", "param"},
                                               {"action", "set"},
                                               {"source", "/a"},
                                               {"destination", "/b"},
                                               {"values", {{"threshold", 0.5}}}}));
    ParamRecvRequest recv;
    static_cast<ParamArguments&>(recv) = param;
    recv.send_took = {0, 2};
    EXPECT_EQ(request_round_trip(recv)["send_took"], json::array({0, 2}));
    param.action = "get";
    param.values = nullptr;
    EXPECT_FALSE(request_round_trip(param).contains("values"));
}

TEST(Operations_test, EveryDaemonReplyRoundTrips) {
    EXPECT_EQ(round_trip(EmptyReply{}), json::object());
    EXPECT_EQ(round_trip(ShmReply{}), json::object());
    EXPECT_EQ(round_trip(ShmReply{2, 8u << 20}), (json{{"region", 2}, {"size", 8u << 20}}));
    EXPECT_EQ(round_trip(ConnectReply{"tcp", {"overlap"}}),
              (json{{"carrier", "tcp"}, {"warnings", {"overlap"}}}));
    EXPECT_EQ(round_trip(AttachReply{{}, "latest", 4, std::nullopt, 0}),
              (json{{"warnings", json::array()}, {"policy", "latest"}, {"capacity", 4}}));
    EXPECT_EQ(round_trip(AttachReply{{}, "strict", 16, 40000, 9}).value("stream", 0), 9);
    EXPECT_EQ(round_trip(PingReply{"n", "127.0.0.1:1"}), (json{{"node", "n"}, {"address", "127.0.0.1:1"}}));
    EXPECT_EQ(round_trip(NodeReply{"n", "h:1", "h:2", "127.0.0.1:8080"}),
              (json{{"node", "n"}, {"address", "h:1"}, {"names", "h:2"}, {"http", "127.0.0.1:8080"}}));
    EXPECT_EQ(round_trip(InspectReply{document_of_inspect()}), document_of_inspect());
    const json document = {{"node", "n"}, {"ports", json::array()}, {"daemon", {{"sessions", 1}}}};
    EXPECT_EQ(round_trip(StatsReply{document}), document);
    EXPECT_EQ(round_trip(EventsReply{document}), document);

    ParamReply param;
    param.monitors.push_back({"certainty", "recv", {{"threshold", 0.8}}});
    param.any_setparam = true;
    param.action = "set";
    param.took = {1};
    EXPECT_EQ(
        round_trip(param),
        (json{{"monitors", {{{"script", "certainty"}, {"side", "recv"}, {"param", {{"threshold", 0.8}}}}}},
              {"any_setparam", true},
              {"action", "set"},
              {"took", {1}}}));
}

TEST(Operations_test, EveryNameServerRequestAndReplyRoundTrips) {
    EXPECT_EQ(request_round_trip(LookupRequest{"/a"}), (json{{"op", "lookup"}, {"port", "/a"}}));
    EXPECT_EQ(request_round_trip(ListRequest{}), (json{{"op", "list"}}));
    EXPECT_EQ(request_round_trip(RegisterNodeRequest{"n", "h:1"}),
              (json{{"op", "register_node"}, {"node", "n"}, {"address", "h:1"}}));
    request_round_trip(RegisterPortRequest{"/a"});
    request_round_trip(UnregisterPortRequest{"/a"});
    EXPECT_EQ(request_round_trip(AddConnectionRequest{"/a", "/b", "tcp", true}),
              (json{{"op", "add_connection"},
                    {"source", "/a"},
                    {"destination", "/b"},
                    {"carrier", "tcp"},
                    {"persistent", true}}));
    EXPECT_EQ(request_round_trip(RemoveConnectionRequest{"/a", "/b", true}),
              (json{{"op", "remove_connection"}, {"source", "/a"}, {"destination", "/b"}, {"forget", true}}));
    request_round_trip(McastGroupRequest{"/a"});
    EXPECT_EQ(request_round_trip(DiscoverRequest{}), (json{{"op", "discover"}}));

    EXPECT_EQ(round_trip(NamesPingReply{"h:1", 2, 3}),
              (json{{"names", "h:1"}, {"auth_failures", 2}, {"handshake_timeouts", 3}}));
    EXPECT_EQ(round_trip(LookupReply{"/a", "n", "h:1"}),
              (json{{"port", "/a"}, {"node", "n"}, {"address", "h:1"}}));
    const json listed = {{"ports", {{{"name", "/a"}, {"node", "n"}, {"address", "h:1"}}}},
                         {"connections", json::array()}};
    EXPECT_EQ(round_trip(ListReply{listed}), listed);
    EXPECT_EQ(round_trip(RegisterPortReply{{{"/a", "/b", "udp"}}}),
              (json{{"persistent", {{{"source", "/a"}, {"destination", "/b"}, {"carrier", "udp"}}}}}));
    EXPECT_EQ(round_trip(McastGroupReply{"239.255.81.1:10102"}), (json{{"group", "239.255.81.1:10102"}}));
    EXPECT_EQ(round_trip(DiscoverReply{"0.0.0.0:10100"}), (json{{"names", "0.0.0.0:10100"}}));
}

TEST(Operations_test, FieldsOfTheWrongTypeAreRefusedNotThrown) {
    const json open = OpenRequest{"/a", "strict", 4}.encode();
    expect_refused<OpenRequest>(open, "port", 5);
    expect_refused<OpenRequest>(open, "policy", nullptr);
    expect_refused<OpenRequest>(open, "capacity", "many");
    expect_refused<OpenRequest>(open, "capacity", -1);
    expect_refused<OpenRequest>(open, "capacity", 1.5);
    expect_refused<CloseRequest>(CloseRequest{1}.encode(), "handle", json::array());
    expect_refused<ShmRequest>(ShmRequest{1, 2}.encode(), "bytes", true);
    const json connect = ConnectRequest{"/a", "/b", "tcp", false, false, false}.encode();
    expect_refused<ConnectRequest>(connect, "source", json::object());
    expect_refused<ConnectRequest>(connect, "strict", "yes");
    expect_refused<ConnectRequest>(connect, "persist", 1);
    expect_refused<ConnectRequest>(connect, "forwarded", "true");
    expect_refused<DisconnectRequest>(DisconnectRequest{"/a", "/b", false}.encode(), "destination", 2);
    expect_refused<AttachRequest>(AttachRequest{"/a", "/b", "mcast", false, "g"}.encode(), "group", 1);
    expect_refused<StatsRequest>(StatsRequest{}.encode(), "port", true);
    expect_refused<EventsRequest>(EventsRequest{"/a", false, false}.encode(), "check", "no");
    expect_refused<PingRequest>(PingRequest{}.encode(), "port", 1.0);
    ParamRequest param;
    param.action = "set";
    expect_refused<ParamRequest>(param.encode(), "values", json::array({1}));
    expect_refused<ParamRequest>(param.encode(), "action", 1);
    expect_refused<ParamRecvRequest>(ParamRecvRequest{}.encode(), "send_took", json::array({-1}));
    expect_refused<ParamRecvRequest>(ParamRecvRequest{}.encode(), "send_took", 3);

    expect_refused<OpenReply>(OpenReply{1, "n"}.encode(), "handle", "1");
    expect_refused<ShmReply>(ShmReply{1, 2}.encode(), "region", -3);
    expect_refused<ConnectReply>(ConnectReply{}.encode(), "warnings", json::array({1}));
    expect_refused<AttachReply>(AttachReply{}.encode(), "udp_port", "40000");
    expect_refused<ParamReply>(ParamReply{}.encode(), "monitors", json::object());
    expect_refused<ParamReply>(ParamReply{}.encode(), "any_setparam", nullptr);
    expect_refused<PingReply>(PingReply{}.encode(), "address", 1);
    expect_refused<NodeReply>(NodeReply{}.encode(), "names", json::array());
    expect_refused<NodeReply>(NodeReply{}.encode(), "http", 8080);
    expect_refused<InspectRequest>(InspectRequest{}.encode(), "only", true);

    expect_refused<LookupRequest>(LookupRequest{"/a"}.encode(), "port", json::array());
    expect_refused<RegisterNodeRequest>(RegisterNodeRequest{}.encode(), "address", 1);
    expect_refused<RegisterPortRequest>(RegisterPortRequest{}.encode(), "port", 1);
    expect_refused<UnregisterPortRequest>(UnregisterPortRequest{}.encode(), "port", 1);
    expect_refused<AddConnectionRequest>(AddConnectionRequest{}.encode(), "persistent", "no");
    expect_refused<RemoveConnectionRequest>(RemoveConnectionRequest{}.encode(), "forget", 0);
    expect_refused<McastGroupRequest>(McastGroupRequest{}.encode(), "port", false);
    expect_refused<NamesPingReply>(NamesPingReply{}.encode(), "auth_failures", -1);
    expect_refused<LookupReply>(LookupReply{}.encode(), "node", 1);
    expect_refused<ListReply>(ListReply{}.encode(), "ports", json::object());
    expect_refused<ListReply>(ListReply{}.encode(), "connections", "none");
    expect_refused<RegisterPortReply>(RegisterPortReply{}.encode(), "persistent", 1);
    expect_refused<McastGroupReply>(McastGroupReply{}.encode(), "group", 1);
    expect_refused<DiscoverReply>(DiscoverReply{}.encode(), "names", 1);
}

TEST(Operations_test, AnEntryOfTheWrongTypeInAListIsRefused) {
    const auto persistent = RegisterPortReply::decode({{"persistent", {{{"source", 1}}}}});
    ASSERT_FALSE(persistent);
    EXPECT_NE(persistent.error().message.find("'source'"), std::string::npos);
    const auto monitors = ParamReply::decode({{"monitors", {"not a map"}}});
    ASSERT_FALSE(monitors);
    EXPECT_NE(monitors.error().message.find("not a map"), std::string::npos);
}

TEST(Operations_test, ABodyThatIsNotAMapIsRefused) {
    for (const json& body : {json::array(), json("open"), json(5), json()}) {
        SCOPED_TRACE(body.dump());
        EXPECT_FALSE(OpenRequest::decode(body));
        EXPECT_FALSE(EmptyReply::decode(body));
        EXPECT_FALSE(StatsReply::decode(body));
        EXPECT_FALSE(ListRequest::decode(body));
    }
}

TEST(Operations_test, TheErrorSaysWhichBodyAndWhatTheFieldMustBe) {
    const auto decoded = OpenRequest::decode({{"op", "open"}, {"port", 5}});
    ASSERT_FALSE(decoded);
    EXPECT_EQ(decoded.error().message, "malformed open request: 'port' must be text");
}

}  // namespace
}  // namespace plexus::proto
