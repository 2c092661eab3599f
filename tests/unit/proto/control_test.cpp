#include "plexus/proto/control.hpp"

#include <gtest/gtest.h>

#include <random>

#include "plexus/proto/frame.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {
namespace {

using nlohmann::json;

Bytes fields_of(const Bytes& frame, FrameType type) {
    const FrameDecode decoded = FrameDecoder().decode(frame);
    EXPECT_EQ(decoded.status, DecodeStatus::frame);
    EXPECT_EQ(decoded.type, type);
    EXPECT_EQ(decoded.used, frame.size());
    return Bytes(decoded.fields.begin(), decoded.fields.end());
}

Bytes request_fields(std::uint64_t id, const Bytes& cbor) {
    Bytes fields;
    append_varint(fields, id);
    fields.insert(fields.end(), cbor.begin(), cbor.end());
    return fields;
}

Bytes reply_fields(std::uint64_t id, std::uint64_t code, const Bytes& cbor) {
    Bytes fields;
    append_varint(fields, id);
    append_varint(fields, code);
    fields.insert(fields.end(), cbor.begin(), cbor.end());
    return fields;
}

const json sample_body = {
    {"op", "connect"},
    {"src", "/a/out"},
    {"dst", "/b/in"},
    {"carrier", "tcp+recv.priority+tc.0.5"},
    {"persist", true},
    {"weights", {1, -2.5, nullptr}},
    {"blob", json::binary({0x00, 0xff, 0x10})},
};

TEST(Request_test, RoundTrips) {
    const Bytes frame = encode_request({1ull << 40, sample_body});
    const auto request = decode_request(fields_of(frame, FrameType::request));
    ASSERT_TRUE(request) << request.error().message;
    EXPECT_EQ(request->id, 1ull << 40);
    EXPECT_EQ(request->body, sample_body);
}

TEST(Request_test, RefusesEveryTruncation) {
    const Bytes fields = fields_of(encode_request({300, sample_body}), FrameType::request);
    for (std::size_t n = 0; n < fields.size(); ++n) {
        EXPECT_FALSE(decode_request(ByteView(fields).first(n))) << "cut at " << n;
    }
}

TEST(Request_test, RefusesBodyThatIsNotAMap) {
    for (const json& body : {json::array({1, 2}), json("connect"), json(5), json(nullptr)}) {
        const auto request = decode_request(request_fields(1, json::to_cbor(body)));
        ASSERT_FALSE(request) << body.dump();
        EXPECT_EQ(request.error().message,
                  "bad request: body is a CBOR " + std::string(body.type_name()) + ", not a map");
    }
}

TEST(Request_test, RefusesMissingOrNonStringOp) {
    const auto missing = decode_request(request_fields(1, json::to_cbor(json{{"src", "/a"}})));
    ASSERT_FALSE(missing);
    EXPECT_EQ(missing.error().message, "bad request: no \"op\"");
    const auto number = decode_request(request_fields(1, json::to_cbor(json{{"op", 3}})));
    ASSERT_FALSE(number);
    EXPECT_EQ(number.error().message, "bad request: \"op\" is a number, not a string");
}

TEST(Request_test, RefusesMissingBody) {
    const auto request = decode_request(request_fields(1, {}));
    ASSERT_FALSE(request);
    EXPECT_EQ(request.error().message, "bad request: missing CBOR body");
}

TEST(Request_test, RefusesGarbageCbor) {
    const Bytes garbage[] = {
        {0xff},                                                       // a "break" with nothing to end
        {0x1c},                                                       // reserved additional information
        {0xa1, 0x61, 'o'},                                            // map cut short
        {0x7b, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 'x'},  // string declaring 2^64-1 bytes
        {0x9b, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff},       // array declaring 2^64-1 items
        {0xa1, 0x01, 0x02},                                           // map with a non-string key
        {0xa0, 0x00},                                                 // a map followed by trailing bytes
    };
    for (const Bytes& cbor : garbage) {
        const auto request = decode_request(request_fields(1, cbor));
        ASSERT_FALSE(request) << cbor.size();
        EXPECT_EQ(request.error().message.rfind("bad request: bad CBOR: ", 0), 0u) << request.error().message;
    }
}

TEST(Request_test, NullBodyIsSentAsEmptyMap) {
    const Bytes fields = fields_of(encode_request({1, {}}), FrameType::request);
    EXPECT_EQ(fields, (Bytes{0x01, 0xa0}));
}

TEST(Reply_test, RoundTripsEveryCode) {
    for (const ReplyCode code :
         {ReplyCode::ok, ReplyCode::no, ReplyCode::usage, ReplyCode::timeout, ReplyCode::refused}) {
        const json body = {{"ports", json::array({"/a", "/b"})}, {"n", 2}};
        const auto reply = decode_reply(fields_of(encode_reply({99, code, body}), FrameType::reply));
        ASSERT_TRUE(reply) << reply.error().message;
        EXPECT_EQ(reply->id, 99u);
        EXPECT_EQ(reply->code, code);
        EXPECT_EQ(reply->body, body);
    }
}

TEST(Reply_test, RoundTripsDefaultReplyAsEmptyMap) {
    const auto reply = decode_reply(fields_of(encode_reply(Reply{5, ReplyCode::ok, {}}), FrameType::reply));
    ASSERT_TRUE(reply) << reply.error().message;
    EXPECT_EQ(reply->code, ReplyCode::ok);
    EXPECT_EQ(reply->body, json::object());
}

TEST(Reply_test, RefusesEveryTruncation) {
    const Bytes fields = fields_of(encode_reply({300, ReplyCode::no, sample_body}), FrameType::reply);
    for (std::size_t n = 0; n < fields.size(); ++n) {
        EXPECT_FALSE(decode_reply(ByteView(fields).first(n))) << "cut at " << n;
    }
}

TEST(Reply_test, RefusesUnknownCode) {
    const auto reply = decode_reply(reply_fields(1, 5, json::to_cbor(json::object())));
    ASSERT_FALSE(reply);
    EXPECT_EQ(reply.error().message, "bad reply: unknown reply code 5");
}

TEST(Reply_test, RefusesBodyThatIsNotAMap) {
    const auto reply = decode_reply(reply_fields(1, 0, json::to_cbor(json::array())));
    ASSERT_FALSE(reply);
    EXPECT_EQ(reply.error().message, "bad reply: body is a CBOR array, not a map");
    EXPECT_FALSE(decode_reply(reply_fields(1, 0, {0xff})));
}

TEST(Reply_test, MakesRefusal) {
    const Reply refusal = make_refusal(8, ReplyCode::refused, "unknown carrier 'foo'");
    const auto reply = decode_reply(fields_of(encode_reply(refusal), FrameType::reply));
    ASSERT_TRUE(reply);
    EXPECT_EQ(reply->id, 8u);
    EXPECT_EQ(reply->code, ReplyCode::refused);
    EXPECT_EQ(reply->body, (json{{"error", "unknown carrier 'foo'"}}));
}

TEST(DecodeCbor_test, RefusesDeepNestingWithoutCrashing) {
    // A million nested one-element arrays would overflow the stack of a recursive reader.
    Bytes deep(1'000'000, 0x81);
    deep.push_back(0x00);
    const auto value = decode_cbor(deep);
    ASSERT_FALSE(value);
    EXPECT_EQ(value.error().message, "bad CBOR: nested deeper than 128 levels");
    // The same through a request.
    EXPECT_FALSE(decode_request(request_fields(1, deep)));
}

TEST(DecodeCbor_test, AcceptsNestingUpToTheLimit) {
    Bytes nested(max_cbor_depth, 0x81);
    nested.push_back(0x00);
    EXPECT_TRUE(decode_cbor(nested));
    nested.insert(nested.begin(), 0x81);
    EXPECT_FALSE(decode_cbor(nested));
}

TEST(DecodeCbor_test, DecodesBinaryAndScalars) {
    const json value = {{"image", json::binary(std::vector<std::uint8_t>(1000, 7))}, {"f", 0.25}};
    const auto decoded = decode_cbor(json::to_cbor(value));
    ASSERT_TRUE(decoded) << decoded.error().message;
    EXPECT_EQ(*decoded, value);
}

TEST(DecodeCbor_test, SurvivesRandomBytes) {
    std::mt19937_64 random(7);
    for (int iteration = 0; iteration < 50'000; ++iteration) {
        Bytes input(random() % 24);
        for (auto& byte : input) {
            byte = static_cast<std::uint8_t>(random());
        }
        // Both outcomes are fine; what matters is that nothing throws or crashes.
        const auto value = decode_cbor(input);
        if (!value) {
            EXPECT_FALSE(value.error().message.empty());
        }
        (void)decode_request(input);
        (void)decode_reply(input);
    }
}

}  // namespace
}  // namespace plexus::proto
