#include "record_codec.hpp"

#include "encoding.hpp"

namespace plexus::mcap {

using format::Opcode;

void append_header(proto::Bytes& out, const std::string& profile, const std::string& library) {
    const auto start = begin_record(out, Opcode::header);
    put_string(out, profile);
    put_string(out, library);
    end_record(out, start);
}

void append_schema(proto::Bytes& out, const Schema& schema) {
    const auto start = begin_record(out, Opcode::schema);
    put_u16(out, schema.id);
    put_string(out, schema.name);
    put_string(out, schema.encoding);
    put_string(out, proto::as_string_view(schema.data));
    end_record(out, start);
}

void append_channel(proto::Bytes& out, const Channel& channel) {
    const auto start = begin_record(out, Opcode::channel);
    put_u16(out, channel.id);
    put_u16(out, channel.schema_id);
    put_string(out, channel.topic);
    put_string(out, channel.message_encoding);
    put_string_map(out, channel.metadata);
    end_record(out, start);
}

void append_message(proto::Bytes& out, std::uint16_t channel_id, std::uint32_t sequence,
                    std::uint64_t log_time, std::uint64_t publish_time, proto::ByteView data) {
    const auto start = begin_record(out, Opcode::message);
    put_u16(out, channel_id);
    put_u32(out, sequence);
    put_u64(out, log_time);
    put_u64(out, publish_time);
    out.insert(out.end(), data.begin(), data.end());
    end_record(out, start);
}

void append_chunk(proto::Bytes& out, const ChunkFields& chunk) {
    const auto start = begin_record(out, Opcode::chunk);
    put_u64(out, chunk.message_start_time);
    put_u64(out, chunk.message_end_time);
    put_u64(out, chunk.uncompressed_size);
    put_u32(out, chunk.uncompressed_crc);
    put_string(out, chunk.compression);
    put_u64(out, chunk.records.size());
    out.insert(out.end(), chunk.records.begin(), chunk.records.end());
    end_record(out, start);
}

void append_message_index(proto::Bytes& out, std::uint16_t channel_id, const MessageIndexEntries& entries) {
    const auto start = begin_record(out, Opcode::message_index);
    put_u16(out, channel_id);
    put_u32(out, static_cast<std::uint32_t>(entries.size() * 16));
    for (const auto& [log_time, offset] : entries) {
        put_u64(out, log_time);
        put_u64(out, offset);
    }
    end_record(out, start);
}

void append_chunk_index(proto::Bytes& out, const ChunkIndexFields& index) {
    const auto start = begin_record(out, Opcode::chunk_index);
    put_u64(out, index.message_start_time);
    put_u64(out, index.message_end_time);
    put_u64(out, index.chunk_start_offset);
    put_u64(out, index.chunk_length);
    put_u32(out, static_cast<std::uint32_t>(index.message_index_offsets.size() * 10));
    for (const auto& [channel, offset] : index.message_index_offsets) {
        put_u16(out, channel);
        put_u64(out, offset);
    }
    put_u64(out, index.message_index_length);
    put_string(out, index.compression);
    put_u64(out, index.compressed_size);
    put_u64(out, index.uncompressed_size);
    end_record(out, start);
}

void append_statistics(proto::Bytes& out, const Statistics& statistics) {
    const auto start = begin_record(out, Opcode::statistics);
    put_u64(out, statistics.message_count);
    put_u16(out, statistics.schema_count);
    put_u32(out, statistics.channel_count);
    put_u32(out, statistics.attachment_count);
    put_u32(out, statistics.metadata_count);
    put_u32(out, statistics.chunk_count);
    put_u64(out, statistics.message_start_time);
    put_u64(out, statistics.message_end_time);
    put_u32(out, static_cast<std::uint32_t>(statistics.channel_message_counts.size() * 10));
    for (const auto& [channel, count] : statistics.channel_message_counts) {
        put_u16(out, channel);
        put_u64(out, count);
    }
    end_record(out, start);
}

void append_metadata(proto::Bytes& out, const Metadata& metadata) {
    const auto start = begin_record(out, Opcode::metadata);
    put_string(out, metadata.name);
    put_string_map(out, metadata.values);
    end_record(out, start);
}

void append_metadata_index(proto::Bytes& out, const MetadataIndexFields& index) {
    const auto start = begin_record(out, Opcode::metadata_index);
    put_u64(out, index.offset);
    put_u64(out, index.length);
    put_string(out, index.name);
    end_record(out, start);
}

void append_summary_offset(proto::Bytes& out, std::uint8_t group_opcode, std::uint64_t group_start,
                           std::uint64_t group_length) {
    const auto start = begin_record(out, Opcode::summary_offset);
    put_u8(out, group_opcode);
    put_u64(out, group_start);
    put_u64(out, group_length);
    end_record(out, start);
}

void append_data_end(proto::Bytes& out, std::uint32_t data_section_crc) {
    const auto start = begin_record(out, Opcode::data_end);
    put_u32(out, data_section_crc);
    end_record(out, start);
}

void append_footer(proto::Bytes& out, const FooterFields& footer) {
    const auto start = begin_record(out, Opcode::footer);
    put_u64(out, footer.summary_start);
    put_u64(out, footer.summary_offset_start);
    put_u32(out, footer.summary_crc);
    end_record(out, start);
}

namespace {

std::uint64_t map_size(const StringMap& map) {
    std::uint64_t size = 4;
    for (const auto& [key, value] : map)
        size += 8 + key.size() + value.size();
    return size;
}

template <typename T>
proto::Result<T> finish(const FieldReader& fields, T value) {
    if (!fields.ok())
        return fields.error();
    return value;
}

}  // namespace

std::uint64_t schema_record_size(const Schema& schema) {
    return format::record_header_size + 2 + 4 + schema.name.size() + 4 + schema.encoding.size() + 4 +
           schema.data.size();
}

std::uint64_t channel_record_size(const Channel& channel) {
    return format::record_header_size + 2 + 2 + 4 + channel.topic.size() + 4 +
           channel.message_encoding.size() + map_size(channel.metadata);
}

std::uint64_t chunk_index_record_size(std::size_t channels, std::size_t compression_length) {
    return format::record_header_size + 8 * 4 + 4 + 10 * channels + 8 + 4 + compression_length + 8 + 8;
}

std::uint64_t statistics_record_size(std::size_t channels) {
    return format::record_header_size + 8 + 2 + 4 * 4 + 8 + 8 + 4 + 10 * channels;
}

std::uint64_t metadata_index_record_size(std::size_t name_length) {
    return format::record_header_size + 8 + 8 + 4 + name_length;
}

proto::Status parse_header(proto::ByteView content, const std::string& where, std::string& profile,
                           std::string& library) {
    FieldReader fields(content, where);
    profile = fields.string("profile");
    library = fields.string("library");
    return finish(fields, proto::Ok{});
}

proto::Result<FooterFields> parse_footer(proto::ByteView content, const std::string& where) {
    FieldReader fields(content, where);
    FooterFields footer;
    footer.summary_start = fields.u64("summary start");
    footer.summary_offset_start = fields.u64("summary offset start");
    footer.summary_crc = fields.u32("summary CRC");
    return finish(fields, footer);
}

proto::Result<Schema> parse_schema(proto::ByteView content, const std::string& where) {
    FieldReader fields(content, where);
    Schema schema;
    schema.id = fields.u16("id");
    schema.name = fields.string("name");
    schema.encoding = fields.string("encoding");
    const auto data = fields.bytes32("data");
    schema.data.assign(data.begin(), data.end());
    return finish(fields, std::move(schema));
}

proto::Result<Channel> parse_channel(proto::ByteView content, const std::string& where) {
    FieldReader fields(content, where);
    Channel channel;
    channel.id = fields.u16("id");
    channel.schema_id = fields.u16("schema id");
    channel.topic = fields.string("topic");
    channel.message_encoding = fields.string("message encoding");
    channel.metadata = fields.string_map("metadata");
    return finish(fields, std::move(channel));
}

proto::Result<MessageView> parse_message(proto::ByteView content, const std::string& where) {
    FieldReader fields(content, where);
    MessageView message;
    message.channel_id = fields.u16("channel id");
    message.sequence = fields.u32("sequence");
    message.log_time = fields.u64("log time");
    message.publish_time = fields.u64("publish time");
    message.data = fields.rest();  // a message record cannot grow fields: its data is the rest
    return finish(fields, message);
}

proto::Result<ChunkFields> parse_chunk(proto::ByteView content, const std::string& where) {
    FieldReader fields(content, where);
    ChunkFields chunk;
    chunk.message_start_time = fields.u64("message start time");
    chunk.message_end_time = fields.u64("message end time");
    chunk.uncompressed_size = fields.u64("uncompressed size");
    chunk.uncompressed_crc = fields.u32("uncompressed CRC");
    chunk.compression = fields.string("compression");
    chunk.records = fields.bytes64("records");
    return finish(fields, std::move(chunk));
}

proto::Result<ChunkIndexFields> parse_chunk_index(proto::ByteView content, const std::string& where) {
    FieldReader fields(content, where);
    ChunkIndexFields index;
    index.message_start_time = fields.u64("message start time");
    index.message_end_time = fields.u64("message end time");
    index.chunk_start_offset = fields.u64("chunk start offset");
    index.chunk_length = fields.u64("chunk length");
    index.message_index_offsets = fields.u16_u64_map("message index offsets");
    index.message_index_length = fields.u64("message index length");
    index.compression = fields.string("compression");
    index.compressed_size = fields.u64("compressed size");
    index.uncompressed_size = fields.u64("uncompressed size");
    return finish(fields, std::move(index));
}

proto::Result<Statistics> parse_statistics(proto::ByteView content, const std::string& where) {
    FieldReader fields(content, where);
    Statistics statistics;
    statistics.message_count = fields.u64("message count");
    statistics.schema_count = fields.u16("schema count");
    statistics.channel_count = fields.u32("channel count");
    statistics.attachment_count = fields.u32("attachment count");
    statistics.metadata_count = fields.u32("metadata count");
    statistics.chunk_count = fields.u32("chunk count");
    statistics.message_start_time = fields.u64("message start time");
    statistics.message_end_time = fields.u64("message end time");
    statistics.channel_message_counts = fields.u16_u64_map("channel message counts");
    return finish(fields, std::move(statistics));
}

proto::Result<Metadata> parse_metadata(proto::ByteView content, const std::string& where) {
    FieldReader fields(content, where);
    Metadata metadata;
    metadata.name = fields.string("name");
    metadata.values = fields.string_map("metadata");
    return finish(fields, std::move(metadata));
}

proto::Result<MetadataIndexFields> parse_metadata_index(proto::ByteView content, const std::string& where) {
    FieldReader fields(content, where);
    MetadataIndexFields index;
    index.offset = fields.u64("offset");
    index.length = fields.u64("length");
    index.name = fields.string("name");
    return finish(fields, std::move(index));
}

proto::Result<std::uint32_t> parse_data_end(proto::ByteView content, const std::string& where) {
    FieldReader fields(content, where);
    const std::uint32_t crc = fields.u32("data section CRC");
    return finish(fields, crc);
}

}  // namespace plexus::mcap
