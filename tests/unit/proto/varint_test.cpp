#include "plexus/proto/varint.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

#include "plexus/proto/fields.hpp"

namespace plexus::proto {
namespace {

constexpr std::uint64_t max_u64 = std::numeric_limits<std::uint64_t>::max();

Bytes encode(std::uint64_t value) {
    Bytes out;
    append_varint(out, value);
    return out;
}

TEST(Varint_test, RoundTripsAtBoundaries) {
    struct Case {
        std::uint64_t value;
        std::size_t size;
    };
    const Case cases[] = {
        {0, 1},           {1, 1},
        {127, 1},         {128, 2},
        {16383, 2},       {16384, 3},
        {1ull << 32, 5},  {(1ull << 63) - 1, 9},
        {1ull << 63, 10}, {max_u64 - 1, 10},
        {max_u64, 10},
    };
    for (const auto& c : cases) {
        const Bytes bytes = encode(c.value);
        EXPECT_EQ(bytes.size(), c.size) << c.value;
        EXPECT_EQ(varint_size(c.value), c.size) << c.value;
        const VarintDecode decoded = decode_varint(bytes);
        ASSERT_EQ(decoded.status, VarintStatus::ok) << c.value;
        EXPECT_EQ(decoded.value, c.value);
        EXPECT_EQ(decoded.used, c.size);
    }
}

TEST(Varint_test, EncodesLowBitsFirst) {
    EXPECT_EQ(encode(0), (Bytes{0x00}));
    EXPECT_EQ(encode(127), (Bytes{0x7f}));
    EXPECT_EQ(encode(128), (Bytes{0x80, 0x01}));
    EXPECT_EQ(encode(300), (Bytes{0xac, 0x02}));
    EXPECT_EQ(encode(1ull << 63), (Bytes{0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x01}));
    EXPECT_EQ(encode(max_u64), (Bytes{0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x01}));
}

TEST(Varint_test, WriteVarintMatchesAppend) {
    for (std::uint64_t value = 1; value != 0; value <<= 1) {
        for (const std::uint64_t v : {value - 1, value, value + 1}) {
            std::uint8_t buffer[max_varint_size];
            const std::size_t used = write_varint(buffer, v);
            EXPECT_EQ(Bytes(buffer, buffer + used), encode(v));
            EXPECT_EQ(used, varint_size(v));
        }
    }
}

TEST(Varint_test, ReadsOnlyItsOwnBytes) {
    const Bytes bytes{0x80, 0x01, 0x55, 0x66};
    const VarintDecode decoded = decode_varint(bytes);
    ASSERT_EQ(decoded.status, VarintStatus::ok);
    EXPECT_EQ(decoded.value, 128u);
    EXPECT_EQ(decoded.used, 2u);
}

TEST(Varint_test, NeedsMoreForEveryTruncation) {
    for (const std::uint64_t value : {std::uint64_t{128}, std::uint64_t{1} << 63, max_u64}) {
        const Bytes bytes = encode(value);
        for (std::size_t n = 0; n < bytes.size(); ++n) {
            EXPECT_EQ(decode_varint(ByteView(bytes).first(n)).status, VarintStatus::need_more)
                << value << " cut at " << n;
        }
    }
}

TEST(Varint_test, RefusesMoreThanTenBytes) {
    // Eleven bytes: ten continuation bytes then a terminator.
    Bytes bytes(10, 0x80);
    bytes.push_back(0x00);
    EXPECT_EQ(decode_varint(bytes).status, VarintStatus::bad);
    // A continuation bit on the tenth byte is refused without waiting for the eleventh.
    Bytes ten(9, 0x80);
    ten.push_back(0x81);
    EXPECT_EQ(decode_varint(ten).status, VarintStatus::bad);
}

TEST(Varint_test, RefusesOverflowPast64Bits) {
    Bytes bytes(9, 0xff);
    bytes.push_back(0x02);  // bit 64
    EXPECT_EQ(decode_varint(bytes).status, VarintStatus::bad);
    bytes.back() = 0x7f;
    EXPECT_EQ(decode_varint(bytes).status, VarintStatus::bad);
    Bytes zeros(9, 0x80);
    zeros.push_back(0x02);
    EXPECT_EQ(decode_varint(zeros).status, VarintStatus::bad);
}

TEST(Varint_test, AcceptsPaddedEncodingWithinTenBytes) {
    // LEB128 allows padding with 0x80 bytes; what matters is the ten-byte and 64-bit limits.
    Bytes bytes(9, 0x80);
    bytes.push_back(0x00);
    const VarintDecode decoded = decode_varint(bytes);
    ASSERT_EQ(decoded.status, VarintStatus::ok);
    EXPECT_EQ(decoded.value, 0u);
    EXPECT_EQ(decoded.used, 10u);
}

/// LEB128 decoded a byte at a time, as the format defines it: the reference for the fast paths.
VarintDecode reference_decode(ByteView input) {
    std::uint64_t value = 0;
    for (std::size_t i = 0; i < max_varint_size; ++i) {
        if (i == input.size())
            return {VarintStatus::need_more};
        const std::uint64_t group = input[i] & 0x7f;
        if (i == max_varint_size - 1 && input[i] > 1)
            return {VarintStatus::bad};
        value |= group << (7 * i);
        if ((input[i] & 0x80) == 0)
            return {VarintStatus::ok, value, i + 1};
    }
    return {VarintStatus::bad};
}

TEST(Varint_test, EveryLengthFollowedByOtherBytesDecodesAsTheReferenceDoes) {
    // Followed by more bytes, a varint takes the eight-bytes-at-once path whatever its length;
    // each length is checked with its groups all ones, all zeros and mixed, and the bytes after
    // it with and without continuation bits (they must not leak into the value).
    for (std::size_t length = 1; length <= max_varint_size; ++length) {
        for (const std::uint8_t group : {0x00, 0x7f, 0x55, 0x2a, 0x01}) {
            for (const std::uint8_t after : {0x00, 0xff, 0x80, 0x7f}) {
                Bytes bytes(length, static_cast<std::uint8_t>(group | 0x80));
                bytes.back() = group;
                if (length == max_varint_size)
                    bytes.back() = group & 1;
                bytes.insert(bytes.end(), 12, after);
                for (std::size_t extra = 0; extra <= 12; ++extra) {
                    const ByteView view = ByteView(bytes).first(length + extra);
                    const VarintDecode fast = decode_varint(view);
                    const VarintDecode reference = reference_decode(view);
                    ASSERT_EQ(fast.status, reference.status) << length << " " << int(group) << " " << extra;
                    EXPECT_EQ(fast.value, reference.value) << length << " " << int(group);
                    EXPECT_EQ(fast.used, reference.used) << length << " " << int(group);
                }
            }
        }
    }
    // And every value around each power of two, with a tail.
    for (int bit = 0; bit < 64; ++bit) {
        const std::uint64_t power = std::uint64_t{1} << bit;
        for (const std::uint64_t value : {power - 1, power, power + 1, power | (power - 1)}) {
            Bytes bytes = encode(value);
            const std::size_t size = bytes.size();
            bytes.insert(bytes.end(), {0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff});
            const VarintDecode decoded = decode_varint(bytes);
            ASSERT_EQ(decoded.status, VarintStatus::ok) << value;
            EXPECT_EQ(decoded.value, value);
            EXPECT_EQ(decoded.used, size) << value;
        }
    }
}

TEST(FieldReader_test, ReadsFieldsInOrder) {
    Bytes body;
    append_varint(body, 300);
    body.push_back(7);
    append_string(body, "/a/b");
    const Bytes blob{1, 2, 3};
    append_bytes(body, blob);
    body.push_back(9);

    FieldReader reader(body);
    EXPECT_EQ(reader.varint("n"), 300u);
    EXPECT_EQ(reader.byte("b"), 7u);
    EXPECT_EQ(reader.string("name", 255), "/a/b");
    const auto bytes = reader.bytes("blob", 3);
    ASSERT_TRUE(bytes);
    EXPECT_EQ(Bytes(bytes->begin(), bytes->end()), blob);
    const auto raw = reader.raw("tail", 1);
    ASSERT_TRUE(raw);
    EXPECT_EQ((*raw)[0], 9u);
    EXPECT_TRUE(reader.rest().empty());
    EXPECT_FALSE(reader.failed());
    EXPECT_EQ(reader.error(), "");
}

TEST(FieldReader_test, RefusesStringLongerThanLimitBeforeReadingIt) {
    Bytes body;
    append_varint(body, 256);
    FieldReader reader(body);
    EXPECT_FALSE(reader.string("source", 255));
    EXPECT_EQ(reader.error(), "source longer than 255 bytes (256)");
}

TEST(FieldReader_test, RefusesHugeDeclaredLengthWithoutAllocating) {
    Bytes body;
    append_varint(body, max_u64);
    body.push_back('x');
    FieldReader reader(body);
    EXPECT_FALSE(reader.bytes("payload", std::numeric_limits<std::size_t>::max()));
    EXPECT_EQ(reader.error(), "truncated payload (declares 18446744073709551615 bytes, 1 left)");
}

TEST(FieldReader_test, NamesTruncatedField) {
    Bytes body;
    append_varint(body, 5);
    body.push_back('a');
    FieldReader reader(body);
    EXPECT_FALSE(reader.string("node", 255));
    EXPECT_EQ(reader.error(), "truncated node (declares 5 bytes, 1 left)");

    FieldReader empty(ByteView{});
    EXPECT_FALSE(empty.varint("seq"));
    EXPECT_EQ(empty.error(), "truncated seq");

    const Bytes overlong(11, 0x80);
    FieldReader bad(overlong);
    EXPECT_FALSE(bad.varint("seq"));
    EXPECT_EQ(bad.error(), "seq is not a valid varint (longer than 10 bytes or over 64 bits)");
}

TEST(FieldReader_test, KeepsFirstFailure) {
    const Bytes body{0x05, 1, 2, 3, 4, 5, 6};
    FieldReader reader(body);
    EXPECT_FALSE(reader.raw("magic", 10));
    EXPECT_FALSE(reader.varint("version"));  // would succeed on its own; the failure sticks
    EXPECT_FALSE(reader.byte("flag"));
    EXPECT_TRUE(reader.failed());
    EXPECT_EQ(reader.error(), "truncated magic");
    EXPECT_TRUE(reader.rest().empty());
}

}  // namespace
}  // namespace plexus::proto
