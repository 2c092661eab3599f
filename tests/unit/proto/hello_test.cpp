#include "plexus/proto/hello.hpp"

#include <gtest/gtest.h>

#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {
namespace {

// The fields of the one frame in `frame`.
Bytes fields_of(const Bytes& frame) {
    const FrameDecode decoded = FrameDecoder().decode(frame);
    EXPECT_EQ(decoded.status, DecodeStatus::frame);
    EXPECT_EQ(decoded.used, frame.size());
    return Bytes(decoded.fields.begin(), decoded.fields.end());
}

Bytes hello_fields(std::uint64_t version, std::string_view role, std::string_view node) {
    Bytes fields{'P', 'L', 'X', 'S'};
    append_varint(fields, version);
    append_string(fields, role);
    append_string(fields, node);
    return fields;
}

TEST(Hello_test, RoundTrips) {
    const Bytes frame = encode_hello({protocol_version, "daemon", "robot-1"});
    ASSERT_EQ(FrameDecoder().decode(frame).type, FrameType::hello);
    const auto hello = decode_hello(fields_of(frame));
    ASSERT_TRUE(hello) << hello.error().message;
    EXPECT_EQ(hello->version, protocol_version);
    EXPECT_EQ(hello->role, "daemon");
    EXPECT_EQ(hello->node, "robot-1");
}

TEST(Hello_test, HasDocumentedLayout) {
    const Bytes fields = fields_of(encode_hello({1, "cli", ""}));
    Bytes expected{'P', 'L', 'X', 'S', 0x01, 0x03, 'c', 'l', 'i', 0x00};
    expected.resize(expected.size() + 32 + 1 + 1, 0);  // nonce, flags, max_frame (0: not said)
    EXPECT_EQ(fields, expected);
}

TEST(Hello_test, CarriesTheSendersMaxFrame) {
    Hello sent{protocol_version, "daemon", "robot-1"};
    sent.max_frame = 64u * 1024u * 1024u;
    const auto hello = decode_hello(fields_of(encode_hello(sent)));
    ASSERT_TRUE(hello) << hello.error().message;
    EXPECT_EQ(hello->max_frame, sent.max_frame);
    // A hello from before max_frame (ending at its flags) says nothing: 0.
    Bytes older = hello_fields(protocol_version, "daemon", "x");
    older.resize(older.size() + 32 + 1, 0);
    const auto old_hello = decode_hello(older);
    ASSERT_TRUE(old_hello) << old_hello.error().message;
    EXPECT_EQ(old_hello->max_frame, 0u);
}

TEST(Hello_test, RoundTripsLimits) {
    const std::string role(64, 'r');
    const std::string node(255, 'n');
    const auto hello = decode_hello(fields_of(encode_hello({0xffffffffu, role, node})));
    ASSERT_TRUE(hello) << hello.error().message;
    EXPECT_EQ(hello->version, 0xffffffffu);
    EXPECT_EQ(hello->role, role);
    EXPECT_EQ(hello->node, node);
}

TEST(Hello_test, RefusesEveryTruncation) {
    const Bytes fields = fields_of(encode_hello({protocol_version, "client", "n"}));
    // A hello may end after its node (a sender with no secret, from before the nonce) or after its
    // flags (from before max_frame); any other cut is refused.
    const std::size_t without_max_frame = fields.size() - 1;
    const std::size_t without_nonce = without_max_frame - 32 - 1;
    for (std::size_t n = 0; n < fields.size(); ++n) {
        const auto hello = decode_hello(ByteView(fields).first(n));
        EXPECT_EQ(hello.ok(), n == without_nonce || n == without_max_frame) << "cut at " << n;
    }
}

TEST(Hello_test, RefusesWrongMagic) {
    Bytes fields = hello_fields(protocol_version, "client", "");
    fields[3] = 'X';
    const auto hello = decode_hello(fields);
    ASSERT_FALSE(hello);
    EXPECT_EQ(hello.error().message, "not a Plexus peer: hello magic is not \"PLXS\"");
}

TEST(Hello_test, RefusesOverlongRoleAndNode) {
    const auto role = decode_hello(hello_fields(protocol_version, std::string(65, 'r'), ""));
    ASSERT_FALSE(role);
    EXPECT_EQ(role.error().message, "hello role longer than 64 bytes (65)");
    const auto node = decode_hello(hello_fields(protocol_version, "daemon", std::string(256, 'n')));
    ASSERT_FALSE(node);
    EXPECT_EQ(node.error().message, "hello node longer than 255 bytes (256)");
}

TEST(Hello_test, RefusesVersionOutOfRange) {
    const auto hello = decode_hello(hello_fields(1ull << 32, "daemon", ""));
    ASSERT_FALSE(hello);
    EXPECT_EQ(hello.error().message, "hello version 4294967296 is out of range");
}

TEST(Hello_test, ReturnsOtherVersionEvenWhenRestDiffers) {
    // A future version may lay out its hello differently after the version; the caller still
    // learns the version and can answer with a version-mismatch error.
    Bytes fields{'P', 'L', 'X', 'S'};
    append_varint(fields, protocol_version + 1);
    fields.push_back(0xff);
    const auto hello = decode_hello(fields);
    ASSERT_TRUE(hello);
    EXPECT_EQ(hello->version, protocol_version + 1);
    EXPECT_EQ(hello->role, "");
}

TEST(Hello_test, IgnoresTrailingFields) {
    Bytes fields = hello_fields(protocol_version, "daemon", "x");
    fields.resize(fields.size() + 32 + 1, 0);  // nonce, flags
    fields.push_back(0x42);                    // max_frame: then fields of a later version
    fields.push_back(0x43);
    const auto hello = decode_hello(fields);
    ASSERT_TRUE(hello);
    EXPECT_EQ(hello->node, "x");
    EXPECT_EQ(hello->max_frame, 0x42u);
}

}  // namespace
}  // namespace plexus::proto

namespace plexus::proto {
namespace {

TEST(HelloAuth_test, CarriesTheNonceAndWhetherTheSenderHoldsTheSecret) {
    Hello hello{protocol_version, "daemon", "arm"};
    hello.nonce[0] = 7;
    hello.nonce[31] = 9;
    hello.has_secret = true;
    const Bytes frame = encode_hello(hello);
    auto decoded = decode_hello(ByteView(frame).subspan(2));
    ASSERT_TRUE(decoded) << decoded.error().message;
    EXPECT_EQ(decoded->nonce, hello.nonce);
    EXPECT_TRUE(decoded->has_secret);
}

TEST(HelloAuth_test, AHelloWithoutTheAppendedFieldsHasNoSecret) {
    Bytes fields{'P', 'L', 'X', 'S', protocol_version, 1, 'c', 0};
    auto decoded = decode_hello(fields);
    ASSERT_TRUE(decoded) << decoded.error().message;
    EXPECT_FALSE(decoded->has_secret);
}

}  // namespace
}  // namespace plexus::proto
