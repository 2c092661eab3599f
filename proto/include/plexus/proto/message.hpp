#pragma once
// A message record: envelope + payload, the bytes that travel unchanged from writer to readers.
//     record = string source | varint seq | varint time_ns | payload (all remaining bytes)
// The payload is CBOR (see payload.hpp in the client); daemons pass it on without decoding it.
// A data frame carries: varint handle | record.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/fields.hpp"

namespace plexus::proto {

inline constexpr std::size_t max_port_name = 255;

struct RecordView {
    std::string_view source;  ///< views into the decoded buffer
    std::uint64_t seq = 0;
    std::uint64_t time_ns = 0;  ///< nanoseconds since the Unix epoch, at the writer
    ByteView payload;
};

/// Appends a record.
void append_record(Bytes& out, std::string_view source, std::uint64_t seq, std::uint64_t time_ns,
                   ByteView payload);
/// Size append_record would add.
std::size_t record_size(std::string_view source, std::uint64_t seq, std::uint64_t time_ns,
                        std::size_t payload_size);
/// Decodes a record; the source must be at most max_port_name bytes.
Result<RecordView> decode_record(ByteView record);
/// The same without the reason when it fails: for the per-message paths that read records the
/// daemon checked on arrival (a monitor's), where building an error's text is never needed.
std::optional<RecordView> read_record(ByteView record);

struct DataView {
    std::uint64_t handle = 0;
    ByteView record;  ///< the record bytes, undecoded
};

/// Appends a whole data frame: header, handle, record.
void append_data_frame(Bytes& out, std::uint64_t handle, ByteView record);
/// Appends just the header and handle of a data frame whose record follows (for gather writes).
void append_data_frame_prefix(Bytes& out, std::uint64_t handle, std::size_t record_size);
/// Decodes the fields of a data frame.
Result<DataView> decode_data(ByteView fields);

// A batch frame carries many records for one handle: consecutive writes on one port, sent and
// forwarded as one unit so that a stream of small messages costs the daemons per batch, not per
// message. Fields: varint handle | varint count | count x (varint length | record).

/// Largest count a batch may declare (a batch of empty records could not be larger than this
/// within the frame limit anyway; the bound keeps the count meaningful before the records are read).
inline constexpr std::uint64_t max_batch_count = 1u << 20;

struct BatchView {
    std::uint64_t handle = 0;
    std::uint64_t count = 0;
    ByteView records;  ///< count x (varint length | record), undecoded
};

/// Decodes the handle and count of a batch frame; the records are checked by BatchRecords.
Result<BatchView> decode_batch(ByteView fields);

/// Walks the records of a batch: next() gives each record in turn, then nullopt. A length that runs
/// past the end, trailing bytes, or fewer records than the count make error() non-empty.
class BatchRecords {
public:
    BatchRecords(ByteView records, std::uint64_t count) : rest_(records), left_(count) {}
    std::optional<ByteView> next() {
        if (left_ == 0 || !error_.empty()) {
            finish();
            return std::nullopt;
        }
        FieldReader reader(rest_);
        const auto record = reader.bytes("record", rest_.size());
        if (!record) {
            fail(reader.error());
            return std::nullopt;
        }
        rest_ = reader.rest();
        --left_;
        return record;
    }
    const std::string& error() const { return error_; }
    /// The records not yet walked.
    ByteView rest() const { return rest_; }

private:
    void finish();  ///< after the last record: anything left over is an error
    void fail(const std::string& why);
    ByteView rest_;
    std::uint64_t left_;
    std::string error_;
};

/// A fast check with no error text, for the daemon's per-record validation: true when `record`
/// starts with `source_field` (the source as append_string writes it) followed by two valid
/// varints. False says only "look closer": decode_record then tells what is wrong, if anything
/// (a source length written as a padded varint, say, which decode_record accepts).
bool record_from(ByteView record, ByteView source_field);
/// The same for every record of a batch's records, which must hold exactly `count` of them.
bool batch_records_from(ByteView records, std::uint64_t count, ByteView source_field);

/// Appends a record to the records of a batch being built: varint length | record.
void append_batch_record(Bytes& out, std::string_view source, std::uint64_t seq, std::uint64_t time_ns,
                         ByteView payload);
/// Appends the header, handle and count of a batch frame whose records (`records_size` bytes,
/// as built by append_batch_record) follow.
void append_batch_frame_prefix(Bytes& out, std::uint64_t handle, std::uint64_t count,
                               std::size_t records_size);

}  // namespace plexus::proto
