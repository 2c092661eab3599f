#include "plexus/proto/shm.hpp"

#include <initializer_list>
#include <optional>

#include "plexus/proto/message.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {

namespace {
/// A frame whose fields are varints, optionally followed by one byte.
Bytes frame_of(FrameType type, std::initializer_list<std::uint64_t> numbers,
               std::optional<std::uint8_t> last = {}) {
    Bytes fields;
    for (const auto number : numbers)
        append_varint(fields, number);
    if (last)
        fields.push_back(*last);
    Bytes frame;
    append_frame(frame, type, fields);
    return frame;
}
}  // namespace

void append_shm_place(Bytes& out, const ShmPlace& place, std::string_view source, std::uint64_t seq,
                      std::uint64_t time_ns) {
    append_varint(out, place.region);
    append_varint(out, place.offset);
    append_varint(out, place.length);
    append_record(out, source, seq, time_ns, {});
}

void append_shm_frame_prefix(Bytes& out, std::uint64_t handle, std::size_t rest_size) {
    append_frame_header(out, FrameType::data_shm, varint_size(handle) + rest_size);
    append_varint(out, handle);
}

Result<ShmDataView> decode_shm_data(ByteView fields) {
    FieldReader reader(fields);
    const auto handle = reader.varint("handle");
    if (!handle)
        return Error{reader.error()};
    auto place = decode_shm_place(reader.rest());
    if (!place)
        return place.error();
    return ShmDataView{*handle, place->place, place->head, reader.rest()};
}

Result<ShmPlaceView> decode_shm_place(ByteView place_and_head) {
    FieldReader reader(place_and_head);
    const auto region = reader.varint("region");
    const auto offset = reader.varint("offset");
    const auto length = reader.varint("length");
    if (!region || !offset || !length)
        return Error{reader.error()};
    const ByteView head = reader.rest();
    auto record = decode_record(head);
    if (!record)
        return record.error();
    if (!record->payload.empty())
        return Error{"data_shm record head followed by " + std::to_string(record->payload.size()) + " bytes"};
    return ShmPlaceView{{*region, *offset, *length}, head};
}

Bytes make_shm_region_frame(const ShmRegionView& region) {
    return frame_of(FrameType::shm_region, {region.region, region.size}, region.writable ? 1 : 0);
}

Result<ShmRegionView> decode_shm_region(ByteView fields) {
    FieldReader reader(fields);
    const auto region = reader.varint("region");
    const auto size = reader.varint("size");
    const auto writable = reader.byte("writable");
    if (!region || !size || !writable)
        return Error{reader.error()};
    return ShmRegionView{*region, *size, *writable != 0};
}

Bytes make_shm_number_frame(FrameType type, std::uint64_t number) {
    return frame_of(type, {number});
}

Result<std::uint64_t> decode_shm_number(ByteView fields, std::string_view what) {
    FieldReader reader(fields);
    const auto number = reader.varint(what);
    if (!number)
        return Error{reader.error()};
    return *number;
}

Bytes make_shm_free_frame(std::uint64_t region, std::uint64_t offset) {
    return frame_of(FrameType::shm_free, {region, offset});
}

Result<std::pair<std::uint64_t, std::uint64_t>> decode_shm_free(ByteView fields) {
    FieldReader reader(fields);
    const auto region = reader.varint("region");
    const auto offset = reader.varint("offset");
    if (!region || !offset)
        return Error{reader.error()};
    return std::pair{*region, *offset};
}

}  // namespace plexus::proto
