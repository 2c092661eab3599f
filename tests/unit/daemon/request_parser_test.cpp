// The name server's parsing of requests, apart from its sockets (names/request_parser.hpp).
#include "names/request_parser.hpp"

#include <gtest/gtest.h>

#include "plexus/proto/frame.hpp"

namespace names = plexus::daemon::names;
namespace proto = plexus::proto;

namespace {

proto::Bytes request_frame(const char* op) {
    return proto::encode_request({7, {{"op", op}}});
}

proto::ByteView fields_of(const proto::Bytes& frame) {
    const auto decoded = proto::FrameDecoder().decode(frame);
    return decoded.fields;
}

}  // namespace

TEST(RequestParser_test, TakesTheRequestOfASessionFrame) {
    const auto frame = request_frame("lookup");
    const auto request = names::parse_session_request(proto::FrameType::request, fields_of(frame));
    ASSERT_TRUE(request);
    EXPECT_EQ(request->id, 7u);
    EXPECT_EQ(request->body["op"], "lookup");
}

TEST(RequestParser_test, RefusesASessionFrameThatIsNotARequest) {
    const auto request = names::parse_session_request(proto::FrameType::data, {});
    ASSERT_FALSE(request);
    EXPECT_EQ(request.error().message, "the name server only takes requests, not data frames");
}

TEST(RequestParser_test, TakesADatagramOfExactlyOneRequestFrame) {
    const auto frame = request_frame("list");
    ASSERT_TRUE(names::parse_datagram_request(frame, 65507));
    auto two = frame;
    two.insert(two.end(), frame.begin(), frame.end());
    const auto refused = names::parse_datagram_request(two, 65507);
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().message, "a datagram must hold exactly one request frame");
    const auto cut = names::parse_datagram_request(proto::ByteView(frame).first(frame.size() - 1), 65507);
    EXPECT_FALSE(cut);
}

TEST(RequestParser_test, AnswersOnlyDiscoveryQueries) {
    EXPECT_TRUE(names::parse_discovery_query(request_frame("discover"), 2048));
    EXPECT_FALSE(names::parse_discovery_query(request_frame("lookup"), 2048));
    const std::uint8_t junk[] = {1, 2, 3};
    EXPECT_FALSE(names::parse_discovery_query(junk, 2048));
}
