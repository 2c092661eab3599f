#include "plexus/proto/message.hpp"

#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {

void append_record(Bytes& out, std::string_view source, std::uint64_t seq, std::uint64_t time_ns,
                   ByteView payload) {
    out.reserve(out.size() + record_size(source, seq, time_ns, payload.size()));
    append_string(out, source);
    append_varint(out, seq);
    append_varint(out, time_ns);
    out.insert(out.end(), payload.begin(), payload.end());
}

std::size_t record_size(std::string_view source, std::uint64_t seq, std::uint64_t time_ns,
                        std::size_t payload_size) {
    return varint_size(source.size()) + source.size() + varint_size(seq) + varint_size(time_ns) +
           payload_size;
}

Result<RecordView> decode_record(ByteView record) {
    FieldReader reader(record);
    const auto source = reader.string("source", max_port_name);
    const auto seq = reader.varint("seq");
    const auto time_ns = reader.varint("time");
    if (reader.failed()) {
        return Error{"bad record: " + reader.error()};
    }
    return RecordView{*source, *seq, *time_ns, reader.rest()};
}

void append_data_frame(Bytes& out, std::uint64_t handle, ByteView record) {
    out.reserve(out.size() + max_varint_size * 2 + 1 + record.size());
    append_data_frame_prefix(out, handle, record.size());
    out.insert(out.end(), record.begin(), record.end());
}

void append_data_frame_prefix(Bytes& out, std::uint64_t handle, std::size_t record_size) {
    append_frame_header(out, FrameType::data, varint_size(handle) + record_size);
    append_varint(out, handle);
}

Result<DataView> decode_data(ByteView fields) {
    FieldReader reader(fields);
    const auto handle = reader.varint("handle");
    if (!handle) {
        return Error{"bad data frame: " + reader.error()};
    }
    return DataView{*handle, reader.rest()};
}

}  // namespace plexus::proto
