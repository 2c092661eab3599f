// The decoders of data and data_batch frames and of message records (message.hpp) on arbitrary
// fields. Properties, when they decode: what they read, written again with the matching append_*,
// reads back the same; the fast checks (record_from, batch_records_from) never say yes to what
// decode_record refuses; read_record (the monitors' lean decoder) takes exactly what decode_record
// takes and reads the same fields.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_check.hpp"
#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/varint.hpp"

namespace proto = plexus::proto;

namespace {

proto::Bytes copy(proto::ByteView bytes) {
    return {bytes.begin(), bytes.end()};
}

/// decode_record, and the same record written again by append_record.
void check_record(proto::ByteView bytes) {
    const auto record = proto::decode_record(bytes);
    const auto lean = proto::read_record(bytes);
    PLEXUS_FUZZ_CHECK(record.ok() == lean.has_value());
    if (!record)
        return;
    PLEXUS_FUZZ_CHECK(lean->source == record->source && lean->seq == record->seq &&
                      lean->time_ns == record->time_ns && lean->payload.data() == record->payload.data() &&
                      lean->payload.size() == record->payload.size());
    PLEXUS_FUZZ_CHECK(record->source.size() <= proto::max_port_name);
    proto::Bytes again;
    proto::append_record(again, record->source, record->seq, record->time_ns, record->payload);
    PLEXUS_FUZZ_CHECK(again.size() == proto::record_size(record->source, record->seq, record->time_ns,
                                                         record->payload.size()));
    const auto reread = proto::decode_record(again);
    PLEXUS_FUZZ_CHECK(reread.ok());
    PLEXUS_FUZZ_CHECK(reread->source == record->source && reread->seq == record->seq &&
                      reread->time_ns == record->time_ns && copy(reread->payload) == copy(record->payload));
    // The fast check agrees with decode_record on a record written the canonical way.
    proto::Bytes source_field;
    proto::append_string(source_field, record->source);
    PLEXUS_FUZZ_CHECK(proto::record_from(again, source_field));
}

void check_data(proto::ByteView fields) {
    const auto data = proto::decode_data(fields);
    if (!data)
        return;
    check_record(data->record);
    proto::Bytes frame;
    proto::append_data_frame(frame, data->handle, data->record);
    const auto decoded = proto::FrameDecoder().decode(frame);
    PLEXUS_FUZZ_CHECK(decoded.status == proto::DecodeStatus::frame && decoded.type == proto::FrameType::data);
    const auto reread = proto::decode_data(decoded.fields);
    PLEXUS_FUZZ_CHECK(reread.ok() && reread->handle == data->handle &&
                      copy(reread->record) == copy(data->record));
}

void check_batch(proto::ByteView fields) {
    const auto batch = proto::decode_batch(fields);
    if (!batch)
        return;
    PLEXUS_FUZZ_CHECK(batch->count <= proto::max_batch_count);
    std::vector<proto::Bytes> records;
    proto::BatchRecords walk(batch->records, batch->count);
    while (const auto record = walk.next()) {
        records.push_back(copy(*record));
        PLEXUS_FUZZ_CHECK(records.size() <= batch->count);
    }
    const bool whole = walk.error().empty();
    PLEXUS_FUZZ_CHECK(!whole || records.size() == batch->count);
    // A source all records of the batch share: the one of the first record that decodes.
    proto::Bytes source_field;
    bool all_from_it = whole;
    for (const auto& record : records) {
        check_record(record);
        const auto decoded = proto::decode_record(record);
        if (!decoded) {
            all_from_it = false;
            continue;
        }
        if (source_field.empty())
            proto::append_string(source_field, decoded->source);
    }
    // batch_records_from saying yes promises every record decodes and the count is exact.
    if (!source_field.empty() && proto::batch_records_from(batch->records, batch->count, source_field))
        PLEXUS_FUZZ_CHECK(all_from_it);
    if (!whole)
        return;
    proto::Bytes body;
    for (const auto& record : records) {
        proto::append_varint(body, record.size());
        body.insert(body.end(), record.begin(), record.end());
    }
    proto::Bytes frame;
    proto::append_batch_frame_prefix(frame, batch->handle, batch->count, body.size());
    frame.insert(frame.end(), body.begin(), body.end());
    const auto decoded = proto::FrameDecoder().decode(frame);
    PLEXUS_FUZZ_CHECK(decoded.status == proto::DecodeStatus::frame &&
                      decoded.type == proto::FrameType::data_batch && decoded.used == frame.size());
    const auto reread = proto::decode_batch(decoded.fields);
    PLEXUS_FUZZ_CHECK(reread.ok() && reread->handle == batch->handle && reread->count == batch->count &&
                      copy(reread->records) == body);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const proto::ByteView input(data, size);
    // The same bytes as each kind of field: a record, a data frame's fields, a batch's fields.
    check_record(input);
    check_data(input);
    check_batch(input);
    return 0;
}
