#pragma once
// The MCAP byte layout in one place (https://mcap.dev/spec, major version 0). Every record is
//   opcode u8 | content length u64 | content
// and every integer is little-endian. Strings are u32 length + UTF-8; maps and arrays are u32
// byte length + entries. The fields of each record, in order:
//   Header 0x01        profile string, library string
//   Footer 0x02        summary_start u64, summary_offset_start u64, summary_crc u32
//                      (CRC32 of [summary_start, the summary_crc field))
//   Schema 0x03        id u16, name string, encoding string, data (u32 length + bytes)
//   Channel 0x04       id u16, schema_id u16, topic string, message_encoding string, metadata
//   map<string,string> Message 0x05       channel_id u16, sequence u32, log_time u64, publish_time u64, data
//   (the rest) Chunk 0x06         message_start_time u64, message_end_time u64, uncompressed_size u64,
//                      uncompressed_crc u32, compression string, records (u64 length + bytes)
//   MessageIndex 0x07  channel_id u16, array<(log_time u64, offset in the uncompressed records u64)>
//   ChunkIndex 0x08    message_start_time u64, message_end_time u64, chunk_start_offset u64,
//                      chunk_length u64, message_index_offsets map<u16,u64>, message_index_length u64,
//                      compression string, compressed_size u64, uncompressed_size u64
//   Statistics 0x0B    message_count u64, schema_count u16, channel_count u32, attachment_count u32,
//                      metadata_count u32, chunk_count u32, message_start_time u64,
//                      message_end_time u64, channel_message_counts map<u16,u64>
//   Metadata 0x0C      name string, metadata map<string,string>
//   MetadataIndex 0x0D offset u64, length u64 (whole record), name string
//   SummaryOffset 0x0E group_opcode u8, group_start u64, group_length u64
//   DataEnd 0x0F       data_section_crc u32 (CRC32 of every byte before the DataEnd record)
// Records may grow new fields at their end: readers ignore bytes after the fields they know.

#include <array>
#include <cstdint>
#include <string_view>

namespace plexus::mcap::format {

inline constexpr std::array<std::uint8_t, 8> magic{0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

enum class Opcode : std::uint8_t {
    header = 0x01,
    footer = 0x02,
    schema = 0x03,
    channel = 0x04,
    message = 0x05,
    chunk = 0x06,
    message_index = 0x07,
    chunk_index = 0x08,
    attachment = 0x09,
    attachment_index = 0x0A,
    statistics = 0x0B,
    metadata = 0x0C,
    metadata_index = 0x0D,
    summary_offset = 0x0E,
    data_end = 0x0F,
};

/// Opcode and content length.
inline constexpr std::uint64_t record_header_size = 9;
/// Footer content: two u64 and a u32.
inline constexpr std::uint64_t footer_content_size = 20;
/// The footer record and the closing magic: the last bytes of every file.
inline constexpr std::uint64_t footer_and_magic_size =
    record_header_size + footer_content_size + magic.size();
/// Message content before its data.
inline constexpr std::uint64_t message_fixed_size = 2 + 4 + 8 + 8;
/// DataEnd record.
inline constexpr std::uint64_t data_end_record_size = record_header_size + 4;

/// The reader's limits, so that no length field makes it allocate without bound.
inline constexpr std::uint64_t max_uncompressed_chunk = std::uint64_t{1} << 30;  // 1 GiB
inline constexpr std::uint64_t max_record =
    max_uncompressed_chunk + 4096;                                      // a chunk's records and its fields
inline constexpr std::uint64_t max_summary = std::uint64_t{256} << 20;  // 256 MiB

/// "chunk", "message", ... for error messages; "unknown (0x42)" style for others.
std::string_view opcode_name(std::uint8_t opcode);

}  // namespace plexus::mcap::format
