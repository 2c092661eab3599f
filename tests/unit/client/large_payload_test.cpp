// Which frames libplexus receives straight into their message (large_payload.hpp): exactly the
// data frames whose whole payload is one untagged CBOR byte string of a large frame.
#include <gtest/gtest.h>

#include "../../../client/src/large_payload.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::detail {
namespace {

proto::Bytes data_frame(const nlohmann::json& value, std::uint64_t handle = 7) {
    proto::Bytes payload;
    proto::encode_cbor(value, payload);
    proto::Bytes record;
    proto::append_record(record, "/camera/image", 42, 1'700'000'000'000'000'000ull, payload);
    proto::Bytes frame;
    proto::append_data_frame(frame, handle, record);
    return frame;
}

TEST(LargePayload_test, ALargeByteStringIsFoundWithItsEnvelopeFromTheFramesStart) {
    const std::vector<std::uint8_t> blob(300 * 1024, 0xab);
    const auto frame = data_frame(Value::binary(blob));
    const proto::ByteView start(frame.data(), 100);  // only the first bytes have arrived

    const auto parsed = parse_large_payload_frame(start, frame.size());

    ASSERT_TRUE(parsed.has_value());
    EXPECT_EQ(parsed->handle, 7u);
    EXPECT_EQ(parsed->envelope.source, "/camera/image");
    EXPECT_EQ(parsed->envelope.seq, 42u);
    EXPECT_EQ(parsed->envelope.time_ns, 1'700'000'000'000'000'000ull);
    EXPECT_EQ(parsed->payload_size, blob.size());
    EXPECT_EQ(parsed->payload_offset + parsed->payload_size, frame.size());
    EXPECT_EQ(frame[parsed->payload_offset], 0xab);
}

TEST(LargePayload_test, OtherFramesTakeTheOrdinaryPath) {
    const std::vector<std::uint8_t> blob(300 * 1024, 1);
    // Small frames, maps holding a blob, text and tagged blobs are decoded as usual.
    const auto small = data_frame(Value::binary(std::vector<std::uint8_t>(1000, 1)));
    EXPECT_FALSE(parse_large_payload_frame(small, small.size()));
    const auto map = data_frame(Value{{"image", Value::binary(blob)}});
    EXPECT_FALSE(parse_large_payload_frame(map, map.size()));
    const auto text = data_frame(std::string(300 * 1024, 'x'));
    EXPECT_FALSE(parse_large_payload_frame(text, text.size()));
    const auto tagged = data_frame(Value::binary(blob, 3));
    EXPECT_FALSE(parse_large_payload_frame(tagged, tagged.size()));
}

TEST(LargePayload_test, AStartTooShortOrAFrameThatDoesNotAddUpIsNotTakenForOne) {
    const auto frame = data_frame(Value::binary(std::vector<std::uint8_t>(300 * 1024, 2)));
    const auto parsed = parse_large_payload_frame({frame.data(), 100}, frame.size());
    ASSERT_TRUE(parsed);
    // Every start that ends before the payload does.
    for (std::size_t cut = 0; cut < parsed->payload_offset; ++cut)
        EXPECT_FALSE(parse_large_payload_frame({frame.data(), cut}, frame.size())) << cut;
    // A frame size other than the one its header gives.
    EXPECT_FALSE(parse_large_payload_frame({frame.data(), 100}, frame.size() + 1));
    // A byte string whose length does not run to the frame's end.
    auto shorter = frame;
    shorter[parsed->payload_offset - 1] ^= 1;  // the last byte of the string's length
    EXPECT_FALSE(parse_large_payload_frame({shorter.data(), 100}, shorter.size()));
    // Not a data frame: the type byte follows the length varint.
    auto other = frame;
    other[proto::decode_varint(frame).used] = static_cast<std::uint8_t>(proto::FrameType::data_batch);
    EXPECT_FALSE(parse_large_payload_frame({other.data(), 100}, other.size()));
}

}  // namespace
}  // namespace plexus::detail
