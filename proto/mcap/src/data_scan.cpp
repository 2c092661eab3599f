#include "data_scan.hpp"

#include <array>

#include "compression.hpp"
#include "crc32.hpp"
#include "encoding.hpp"
#include "format.hpp"
#include "record_codec.hpp"

namespace plexus::mcap {

std::string at_offset(std::uint64_t offset) {
    return "offset " + std::to_string(offset) + ": ";
}

namespace {

std::string name_of(std::uint8_t opcode) {
    const std::string_view name = format::opcode_name(opcode);
    if (name != "unknown")
        return std::string(name);
    return "unknown (opcode " + std::to_string(opcode) + ")";
}

/// Decodes the chunk record's content into its uncompressed records, checking sizes and CRC.
proto::Status unpack_chunk(const ScannedRecord& chunk_record, proto::Bytes& records) {
    auto chunk = parse_chunk(chunk_record.content, chunk_record.where());
    if (!chunk)
        return chunk.error();
    const std::string where = at_offset(chunk_record.offset) + "chunk record: ";
    if (chunk->uncompressed_size > format::max_uncompressed_chunk)
        return proto::Error{where + "its uncompressed size " + std::to_string(chunk->uncompressed_size) +
                            " exceeds this reader's limit of " +
                            std::to_string(format::max_uncompressed_chunk)};
    if (chunk->compression.empty()) {
        if (chunk->records.size() != chunk->uncompressed_size)
            return proto::Error{where + "uncompressed records of " + std::to_string(chunk->records.size()) +
                                " bytes, the chunk declares " + std::to_string(chunk->uncompressed_size)};
        records.assign(chunk->records.begin(), chunk->records.end());
    } else if (chunk->compression == "zstd") {
        if (auto status = zstd_decompress(chunk->records, chunk->uncompressed_size, records); !status)
            return proto::Error{where + status.error().message};
    } else {
        return proto::Error{where + "compression \"" + chunk->compression +
                            "\" is not supported (only zstd)"};
    }
    if (chunk->uncompressed_crc != 0) {
        const std::uint32_t actual = crc32(records);
        if (actual != chunk->uncompressed_crc)
            return proto::Error{where + "chunk CRC mismatch (the chunk says " +
                                std::to_string(chunk->uncompressed_crc) + ", its records give " +
                                std::to_string(actual) + ")"};
    }
    return proto::Ok{};
}

/// Hands each record of an uncompressed chunk to the visitor; answers false if it stopped.
proto::Result<bool> visit_chunk_records(std::uint64_t chunk_offset, proto::ByteView records,
                                        const ScanVisitor& visitor) {
    std::size_t position = 0;
    while (position < records.size()) {
        const std::size_t left = records.size() - position;
        const std::string where = at_offset(chunk_offset) + "chunk record: ";
        if (left < format::record_header_size)
            return proto::Error{where + "its records end inside a record header at uncompressed byte " +
                                std::to_string(position)};
        const std::uint8_t opcode = records[position];
        const std::uint64_t length = load_u64(records.data() + position + 1);
        if (length > left - format::record_header_size)
            return proto::Error{where + "its " + name_of(opcode) + " record at uncompressed byte " +
                                std::to_string(position) + " runs past the end of the records"};
        ScannedRecord record;
        record.opcode = opcode;
        record.content =
            records.subspan(position + format::record_header_size, static_cast<std::size_t>(length));
        record.offset = chunk_offset;
        record.position_in_chunk = position;
        auto go_on = visitor.record(record);
        if (!go_on || !*go_on)
            return go_on;
        position += format::record_header_size + static_cast<std::size_t>(length);
    }
    return true;
}

}  // namespace

std::string ScannedRecord::where() const {
    if (position_in_chunk)
        return at_offset(offset) + "chunk record, " + name_of(opcode) + " record at uncompressed byte " +
               std::to_string(*position_in_chunk);
    return at_offset(offset) + name_of(opcode) + " record";
}

proto::Result<RecordHeader> read_record_header(const InputSource& source, std::uint64_t offset,
                                               std::uint64_t limit, const std::string& region) {
    if (offset > limit || limit - offset < format::record_header_size)
        return proto::Error{at_offset(offset) + "the " + region + " ends inside a record header"};
    std::array<std::uint8_t, format::record_header_size> bytes{};
    if (auto status = source.read(offset, bytes); !status)
        return status.error();
    RecordHeader header;
    header.opcode = bytes[0];
    header.offset = offset;
    header.length = load_u64(bytes.data() + 1);
    if (header.length > limit - offset - format::record_header_size)
        return proto::Error{at_offset(offset) + "the " + name_of(header.opcode) + " record's length " +
                            std::to_string(header.length) + " runs past the end of the " + region +
                            " at offset " + std::to_string(limit)};
    return header;
}

proto::Status scan_data_section(const InputSource& source, std::uint64_t begin, std::uint64_t end,
                                const ScanVisitor& visitor) {
    // The DataEnd CRC covers every byte before it, the magic and Header included.
    Crc32 crc;
    bool crc_complete = true;
    proto::Bytes content;
    if (auto status = read_bytes(source, 0, begin, content); !status)
        return status;
    crc.update(content);
    proto::Bytes records;
    std::uint64_t offset = begin;
    while (offset < end) {
        auto header = read_record_header(source, offset, end, "data section");
        if (!header)
            return header.error();
        if (header->length > format::max_record)
            return proto::Error{at_offset(offset) + "the " + name_of(header->opcode) + " record's length " +
                                std::to_string(header->length) + " exceeds this reader's limit"};
        const bool is_chunk = header->opcode == static_cast<std::uint8_t>(format::Opcode::chunk);
        if (is_chunk && visitor.want_chunk && !visitor.want_chunk(offset)) {
            crc_complete = false;
            offset = header->end();
            continue;
        }
        if (auto status = read_bytes(source, offset, format::record_header_size + header->length, content);
            !status)
            return status;
        ScannedRecord record;
        record.opcode = header->opcode;
        record.content = proto::ByteView(content).subspan(format::record_header_size);
        record.offset = offset;
        if (header->opcode == static_cast<std::uint8_t>(format::Opcode::data_end)) {
            auto stated = parse_data_end(record.content, record.where());
            if (!stated)
                return stated.error();
            if (crc_complete && *stated != 0 && *stated != crc.value())
                return proto::Error{at_offset(offset) +
                                    "data section CRC mismatch (the data end record says " +
                                    std::to_string(*stated) + ", the bytes before it give " +
                                    std::to_string(crc.value()) + ")"};
            return proto::Ok{};  // the data section is over
        }
        crc.update(content);
        auto go_on = visitor.record(record);
        if (!go_on)
            return go_on.error();
        if (!*go_on)
            return proto::Ok{};
        if (is_chunk) {
            if (auto status = unpack_chunk(record, records); !status)
                return status;
            auto more = visit_chunk_records(offset, records, visitor);
            if (!more)
                return more.error();
            if (!*more)
                return proto::Ok{};
        }
        offset = header->end();
    }
    // Every writer ends the data section with DataEnd; a scan that misses it has been led off
    // the records by a damaged length, and its CRC check would be skipped.
    return proto::Error{at_offset(end) + "the data section ends without a data end record"};
}

proto::Error truncation_error(const InputSource& source, std::uint64_t begin) {
    const std::uint64_t size = source.size();
    std::uint64_t offset = begin;
    std::string last = "header";
    while (true) {
        if (offset == size)
            return {at_offset(size) + "truncated: the file ends after a complete " + last +
                    " record (no footer)"};
        if (size - offset < format::record_header_size)
            return {at_offset(offset) + "truncated: the file ends inside a record header (no footer)"};
        std::array<std::uint8_t, format::record_header_size> bytes{};
        if (auto status = source.read(offset, bytes); !status)
            return status.error();
        last = name_of(bytes[0]);
        const std::uint64_t length = load_u64(bytes.data() + 1);
        if (length > size - offset - format::record_header_size)
            return {at_offset(offset) + "truncated: the file ends inside a " + last + " record (no footer)"};
        offset += format::record_header_size + length;
    }
}

}  // namespace plexus::mcap
