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
    EXPECT_EQ(fields, (Bytes{'P', 'L', 'X', 'S', 0x01, 0x03, 'c', 'l', 'i', 0x00}));
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
    for (std::size_t n = 0; n < fields.size(); ++n) {
        const auto hello = decode_hello(ByteView(fields).first(n));
        EXPECT_FALSE(hello) << "cut at " << n;
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
    fields.push_back(0x42);
    const auto hello = decode_hello(fields);
    ASSERT_TRUE(hello);
    EXPECT_EQ(hello->node, "x");
}

}  // namespace
}  // namespace plexus::proto
