#pragma once
// A message record: envelope + payload, the bytes that travel unchanged from writer to readers.
//     record = string source | varint seq | varint time_ns | payload (all remaining bytes)
// The payload is CBOR (see payload.hpp in the client); daemons pass it on without decoding it.
// A data frame carries: varint handle | record.

#include <cstdint>
#include <string_view>

#include "plexus/proto/bytes.hpp"

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

}  // namespace plexus::proto
