// Frames of the shared-memory path (plexus/proto/shm.hpp).
#include "plexus/proto/shm.hpp"

#include <gtest/gtest.h>

#include "plexus/proto/message.hpp"

namespace plexus::proto {
namespace {

ByteView fields_of(const Bytes& frame) {
    const auto decoded = FrameDecoder().decode(frame);
    EXPECT_EQ(decoded.status, DecodeStatus::frame) << decoded.error;
    return decoded.fields;
}

TEST(ShmFrames_test, ADataShmFrameCarriesItsPlaceAndTheRecordHead) {
    Bytes place;
    append_shm_place(place, {3, 4096, 1048576}, "/camera/image", 42, 1'700'000'000'000'000'000ull);
    Bytes frame;
    append_shm_frame_prefix(frame, 9, place.size());
    frame.insert(frame.end(), place.begin(), place.end());

    const auto decoded = FrameDecoder().decode(frame);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    EXPECT_EQ(decoded.type, FrameType::data_shm);
    const auto data = decode_shm_data(decoded.fields);
    ASSERT_TRUE(data.ok()) << data.error().message;
    EXPECT_EQ(data->handle, 9u);
    EXPECT_EQ(data->place.region, 3u);
    EXPECT_EQ(data->place.offset, 4096u);
    EXPECT_EQ(data->place.length, 1048576u);
    EXPECT_EQ(Bytes(data->place_and_head.begin(), data->place_and_head.end()), place);
    const auto head = decode_record(data->head);
    ASSERT_TRUE(head.ok());
    EXPECT_EQ(head->source, "/camera/image");
    EXPECT_EQ(head->seq, 42u);
    EXPECT_TRUE(head->payload.empty());
}

TEST(ShmFrames_test, ADataShmFrameWithPayloadBytesAfterTheHeadOrCutShortIsRefused) {
    Bytes place;
    append_shm_place(place, {1, 0, 10}, "/a", 1, 1);
    Bytes with_payload = place;
    with_payload.push_back(0x01);
    Bytes fields{0x05};
    fields.insert(fields.end(), with_payload.begin(), with_payload.end());
    const auto refused = decode_shm_data(fields);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.error().message.find("followed by 1 bytes"), std::string::npos)
        << refused.error().message;
    for (std::size_t cut = 0; cut < place.size(); ++cut) {
        Bytes short_fields{0x05};
        short_fields.insert(short_fields.end(), place.begin(),
                            place.begin() + static_cast<std::ptrdiff_t>(cut));
        EXPECT_FALSE(decode_shm_data(short_fields).ok()) << "cut at " << cut;
    }
}

TEST(ShmFrames_test, RegionFreeReleaseAndGoneFramesRoundTrip) {
    const auto region = decode_shm_region(fields_of(make_shm_region_frame({7, 33554432, true})));
    ASSERT_TRUE(region.ok());
    EXPECT_EQ(region->region, 7u);
    EXPECT_EQ(region->size, 33554432u);
    EXPECT_TRUE(region->writable);
    const auto freed = decode_shm_free(fields_of(make_shm_free_frame(7, 65536)));
    ASSERT_TRUE(freed.ok());
    EXPECT_EQ(freed->first, 7u);
    EXPECT_EQ(freed->second, 65536u);
    const auto released =
        decode_shm_number(fields_of(make_shm_number_frame(FrameType::shm_release, 300)), "count");
    ASSERT_TRUE(released.ok());
    EXPECT_EQ(*released, 300u);
    EXPECT_EQ(frame_type_name(static_cast<std::uint8_t>(FrameType::shm_region_gone)), "shm_region_gone");
    EXPECT_FALSE(decode_shm_region(Bytes{0x01, 0x02}).ok()) << "a region frame without its flag";
}

}  // namespace
}  // namespace plexus::proto
