#pragma once
// Walking records in file order: record headers checked against the region they must fit in,
// and the data section scanned record by record with each chunk read, decompressed and
// CRC-checked once. Shared by for_each_message and by opening a file that has no summary.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "input_source.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::mcap {

/// "offset 1234: ", how errors say where in the file they are.
std::string at_offset(std::uint64_t offset);

struct RecordHeader {
    std::uint8_t opcode = 0;
    std::uint64_t offset = 0;  ///< of the opcode byte
    std::uint64_t length = 0;  ///< of the content, which starts at offset + 9
    std::uint64_t end() const { return offset + 9 + length; }
};

/// The header of the record at `offset`, which must end by `limit` (the end of `region`, named in errors).
proto::Result<RecordHeader> read_record_header(const InputSource& source, std::uint64_t offset,
                                               std::uint64_t limit, const std::string& region);

/// One record met by a scan: outside chunks, or inside the chunk at `offset`.
struct ScannedRecord {
    std::uint8_t opcode = 0;
    proto::ByteView content;
    std::uint64_t offset = 0;                        ///< the record's offset, or its chunk's
    std::optional<std::uint64_t> position_in_chunk;  ///< in the uncompressed records, for records in a chunk
    /// "offset 1234: message record" or "offset 1234: chunk record, message record at uncompressed byte 56".
    std::string where() const;
};

struct ScanVisitor {
    /// Every record from `begin` to the DataEnd record, chunks first as themselves then their
    /// records; false stops the scan.
    std::function<proto::Result<bool>(const ScannedRecord&)> record;
    /// Whether to read the chunk at this offset (absent: all).
    std::function<bool(std::uint64_t)> want_chunk;
};

/// Scans [begin, end) of the data section up to its DataEnd record, whose absence is an error.
/// When every byte was read (no chunk skipped), checks DataEnd's CRC of [0, DataEnd).
proto::Status scan_data_section(const InputSource& source, std::uint64_t begin, std::uint64_t end,
                                const ScanVisitor& visitor);

/// The error for a file with no footer: where, scanning from `begin`, the records stop fitting.
proto::Error truncation_error(const InputSource& source, std::uint64_t begin);

}  // namespace plexus::mcap
