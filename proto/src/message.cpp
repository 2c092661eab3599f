#include "plexus/proto/message.hpp"

#include <cstring>

#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {

namespace {

/// Writes a record at `cursor`, which has room for it; returns the end.
std::uint8_t* write_record(std::uint8_t* cursor, std::string_view source, std::uint64_t seq,
                           std::uint64_t time_ns, ByteView payload) {
    cursor += write_varint(cursor, source.size());
    std::memcpy(cursor, source.data(), source.size());
    cursor += source.size();
    cursor += write_varint(cursor, seq);
    cursor += write_varint(cursor, time_ns);
    if (!payload.empty())
        std::memcpy(cursor, payload.data(), payload.size());
    return cursor + payload.size();
}

}  // namespace

void append_record(Bytes& out, std::string_view source, std::uint64_t seq, std::uint64_t time_ns,
                   ByteView payload) {
    // One resize and direct writes: every message written goes through here.
    const std::size_t at = out.size();
    out.resize(at + record_size(source, seq, time_ns, payload.size()));
    write_record(out.data() + at, source, seq, time_ns, payload);
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

std::optional<RecordView> read_record(ByteView record) {
    auto length = decode_varint(record);
    if (length.status != VarintStatus::ok || length.value > max_port_name ||
        length.value > record.size() - length.used)
        return std::nullopt;
    ByteView rest = record.subspan(length.used);
    const auto source = as_string_view(rest.first(static_cast<std::size_t>(length.value)));
    rest = rest.subspan(source.size());
    const auto seq = decode_varint(rest);
    if (seq.status != VarintStatus::ok)
        return std::nullopt;
    rest = rest.subspan(seq.used);
    const auto time_ns = decode_varint(rest);
    if (time_ns.status != VarintStatus::ok)
        return std::nullopt;
    return RecordView{source, seq.value, time_ns.value, rest.subspan(time_ns.used)};
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

Result<BatchView> decode_batch(ByteView fields) {
    FieldReader reader(fields);
    const auto handle = reader.varint("handle");
    const auto count = reader.varint("count");
    if (reader.failed())
        return Error{"bad batch frame: " + reader.error()};
    if (*count == 0 || *count > max_batch_count) {
        return Error{"bad batch frame: count " + std::to_string(*count) + " outside 1.." +
                     std::to_string(max_batch_count)};
    }
    return BatchView{*handle, *count, reader.rest()};
}

void BatchRecords::finish() {
    if (error_.empty() && left_ == 0 && !rest_.empty())
        error_ = "bad batch frame: " + std::to_string(rest_.size()) + " bytes after the last record";
}

void BatchRecords::fail(const std::string& why) {
    error_ = "bad batch frame: " + why + " (" + std::to_string(left_) + " records left)";
}

bool record_from(ByteView record, ByteView source_field) {
    if (record.size() < source_field.size() ||
        std::memcmp(record.data(), source_field.data(), source_field.size()) != 0)
        return false;
    ByteView rest = record.subspan(source_field.size());
    const auto seq = decode_varint(rest);
    if (seq.status != VarintStatus::ok)
        return false;
    return decode_varint(rest.subspan(seq.used)).status == VarintStatus::ok;
}

bool batch_records_from(ByteView records, std::uint64_t count, ByteView source_field) {
    for (std::uint64_t i = 0; i < count; ++i) {
        const auto length = decode_varint(records);
        if (length.status != VarintStatus::ok || length.value > records.size() - length.used)
            return false;
        const ByteView record = records.subspan(length.used, static_cast<std::size_t>(length.value));
        if (!record_from(record, source_field))
            return false;
        records = records.subspan(length.used + record.size());
    }
    return records.empty();
}

void append_batch_record(Bytes& out, std::string_view source, std::uint64_t seq, std::uint64_t time_ns,
                         ByteView payload) {
    const std::size_t size = record_size(source, seq, time_ns, payload.size());
    const std::size_t at = out.size();
    out.resize(at + varint_size(size) + size);
    std::uint8_t* cursor = out.data() + at;
    cursor += write_varint(cursor, size);
    write_record(cursor, source, seq, time_ns, payload);
}

void append_batch_frame_prefix(Bytes& out, std::uint64_t handle, std::uint64_t count,
                               std::size_t records_size) {
    append_frame_header(out, FrameType::data_batch, varint_size(handle) + varint_size(count) + records_size);
    append_varint(out, handle);
    append_varint(out, count);
}

}  // namespace plexus::proto
