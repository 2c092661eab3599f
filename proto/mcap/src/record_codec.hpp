#pragma once
// Each MCAP record to bytes and back (field order in format.hpp). Parsers take one record's
// content and a `where` ("offset 1234: chunk record") that starts their error messages; they
// check every length and ignore fields added after the ones they know.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "plexus/mcap/reader.hpp"
#include "plexus/mcap/records.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::mcap {

struct ChunkFields {
    std::uint64_t message_start_time = 0;
    std::uint64_t message_end_time = 0;
    std::uint64_t uncompressed_size = 0;
    std::uint32_t uncompressed_crc = 0;
    std::string compression;
    proto::ByteView records;  ///< compressed as `compression` says
};

struct ChunkIndexFields {
    std::uint64_t message_start_time = 0;
    std::uint64_t message_end_time = 0;
    std::uint64_t chunk_start_offset = 0;
    std::uint64_t chunk_length = 0;
    std::map<std::uint16_t, std::uint64_t> message_index_offsets;
    std::uint64_t message_index_length = 0;
    std::string compression;
    std::uint64_t compressed_size = 0;
    std::uint64_t uncompressed_size = 0;
};

struct MetadataIndexFields {
    std::uint64_t offset = 0;
    std::uint64_t length = 0;
    std::string name;
};

struct FooterFields {
    std::uint64_t summary_start = 0;
    std::uint64_t summary_offset_start = 0;
    std::uint32_t summary_crc = 0;
};

using MessageIndexEntries = std::vector<std::pair<std::uint64_t, std::uint64_t>>;  ///< (log_time, offset)

void append_header(proto::Bytes& out, const std::string& profile, const std::string& library);
void append_schema(proto::Bytes& out, const Schema& schema);
void append_channel(proto::Bytes& out, const Channel& channel);
void append_message(proto::Bytes& out, std::uint16_t channel_id, std::uint32_t sequence,
                    std::uint64_t log_time, std::uint64_t publish_time, proto::ByteView data);
void append_chunk(proto::Bytes& out, const ChunkFields& chunk);
void append_message_index(proto::Bytes& out, std::uint16_t channel_id, const MessageIndexEntries& entries);
void append_chunk_index(proto::Bytes& out, const ChunkIndexFields& index);
void append_statistics(proto::Bytes& out, const Statistics& statistics);
void append_metadata(proto::Bytes& out, const Metadata& metadata);
void append_metadata_index(proto::Bytes& out, const MetadataIndexFields& index);
void append_summary_offset(proto::Bytes& out, std::uint8_t group_opcode, std::uint64_t group_start,
                           std::uint64_t group_length);
void append_data_end(proto::Bytes& out, std::uint32_t data_section_crc);
void append_footer(proto::Bytes& out, const FooterFields& footer);

/// Sizes of whole records, for the writer's estimate of the summary it owes.
std::uint64_t schema_record_size(const Schema& schema);
std::uint64_t channel_record_size(const Channel& channel);
std::uint64_t chunk_index_record_size(std::size_t channels, std::size_t compression_length);
std::uint64_t statistics_record_size(std::size_t channels);
std::uint64_t metadata_index_record_size(std::size_t name_length);

proto::Status parse_header(proto::ByteView content, const std::string& where, std::string& profile,
                           std::string& library);
proto::Result<FooterFields> parse_footer(proto::ByteView content, const std::string& where);
proto::Result<Schema> parse_schema(proto::ByteView content, const std::string& where);
proto::Result<Channel> parse_channel(proto::ByteView content, const std::string& where);
proto::Result<MessageView> parse_message(proto::ByteView content, const std::string& where);
proto::Result<ChunkFields> parse_chunk(proto::ByteView content, const std::string& where);
proto::Result<ChunkIndexFields> parse_chunk_index(proto::ByteView content, const std::string& where);
proto::Result<Statistics> parse_statistics(proto::ByteView content, const std::string& where);
proto::Result<Metadata> parse_metadata(proto::ByteView content, const std::string& where);
proto::Result<MetadataIndexFields> parse_metadata_index(proto::ByteView content, const std::string& where);
proto::Result<std::uint32_t> parse_data_end(proto::ByteView content, const std::string& where);

}  // namespace plexus::mcap
