#include "plexus/mcap/writer.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "compression.hpp"
#include "crc32.hpp"
#include "format.hpp"
#include "record_codec.hpp"

namespace plexus::mcap {

namespace {

// Room kept free beyond the summary we can count, for what the count does not foresee.
constexpr std::uint64_t reserve_margin = 64 * 1024;

bool is_disk_full(int error_number) {
    return error_number == ENOSPC || error_number == EFBIG || error_number == EDQUOT;
}

}  // namespace

struct Writer::ChunkIndexEntry : ChunkIndexFields {};
struct Writer::MetadataIndexEntry : MetadataIndexFields {};

/// The chunk being filled: its records uncompressed, and what its index and statistics will say.
struct Writer::OpenChunk {
    proto::Bytes records;
    std::uint64_t start_time = 0;
    std::uint64_t end_time = 0;
    std::uint64_t message_count = 0;
    std::uint64_t message_bytes = 0;
    std::map<std::uint16_t, MessageIndexEntries> indexes;
    std::set<std::uint16_t> schemas_added;  // their records are in `records`, not yet in the file
    std::set<std::uint16_t> channels_added;
};

Writer::Writer(std::unique_ptr<OutputFile> file, WriterOptions options)
    : file_(std::move(file)), options_(std::move(options)), chunk_(std::make_unique<OpenChunk>()) {}

Writer::~Writer() {
    if (!closed_)
        (void)close();
}

proto::Result<std::unique_ptr<Writer>> Writer::create(const std::string& path, WriterOptions options) {
    auto file = create_output_file(path);
    if (!file)
        return file.error();
    auto writer = create_on(std::move(*file), std::move(options));
    if (!writer)
        std::remove(path.c_str());  // ours (O_EXCL) and holding at most part of a header
    return writer;
}

proto::Result<std::unique_ptr<Writer>> Writer::create_on(std::unique_ptr<OutputFile> file,
                                                         WriterOptions options) {
    if (options.compression != "zstd" && !options.compression.empty())
        return proto::Error{"MCAP compression \"" + options.compression +
                            "\" is not supported (use \"zstd\" or \"\")"};
    if (options.chunk_bytes == 0)
        return proto::Error{"MCAP chunk size must be at least 1 byte"};
    std::unique_ptr<Writer> writer(new Writer(std::move(file), std::move(options)));
    if (auto status = writer->write_header(); !status) {
        writer->closed_ = true;  // nothing worth finalizing
        return status.error();
    }
    return writer;
}

proto::Status Writer::write_header() {
    proto::Bytes block(format::magic.begin(), format::magic.end());
    append_header(block, options_.profile, "plexus");
    return write_block(block, 0);
}

std::uint16_t Writer::add_schema(const std::string& name, const std::string& encoding, proto::ByteView data) {
    const std::size_t next = schemas_.empty() ? 1 : std::size_t{schemas_.rbegin()->first} + 1;
    if (next > 0xFFFF)
        return 0;
    const auto id = static_cast<std::uint16_t>(next);
    schemas_[id] = Schema{id, name, encoding, proto::Bytes(data.begin(), data.end())};
    return id;
}

proto::Result<std::uint16_t> Writer::add_channel(const std::string& topic,
                                                 const std::string& message_encoding, StringMap metadata,
                                                 std::uint16_t schema_id) {
    if (schema_id != 0 && schemas_.count(schema_id) == 0)
        return proto::Error{"MCAP channel " + topic + ": no schema has id " + std::to_string(schema_id)};
    const std::size_t next = channels_.empty() ? 1 : std::size_t{channels_.rbegin()->first} + 1;
    if (next > 0xFFFF)
        return proto::Error{"MCAP channel " + topic + ": all 65535 channel ids are taken"};
    const auto id = static_cast<std::uint16_t>(next);
    channels_[id] = Channel{id, schema_id, topic, message_encoding, std::move(metadata)};
    return id;
}

void Writer::append_channel_records(std::uint16_t channel_id) {
    // The spec wants a channel's record (and its schema's) before the channel's first message;
    // putting them in the same chunk keeps each chunk readable on its own.
    const Channel& channel = channels_.at(channel_id);
    const std::uint16_t schema_id = channel.schema_id;
    if (schema_id != 0 && schemas_in_file_.count(schema_id) == 0 &&
        chunk_->schemas_added.count(schema_id) == 0) {
        append_schema(chunk_->records, schemas_.at(schema_id));
        chunk_->schemas_added.insert(schema_id);
    }
    if (channels_in_file_.count(channel_id) == 0 && chunk_->channels_added.count(channel_id) == 0) {
        append_channel(chunk_->records, channel);
        chunk_->channels_added.insert(channel_id);
    }
}

proto::Status Writer::write_message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                                    std::uint64_t publish_time, proto::ByteView data) {
    if (closed_)
        return proto::Error{"the MCAP file " + file_->path() + " is closed"};
    if (channels_.count(channel_id) == 0)
        return proto::Error{"MCAP: no channel has id " + std::to_string(channel_id)};
    if (failed()) {
        ++lost_messages_;
        lost_bytes_ += data.size();
        return proto::Error{error_};
    }
    const std::uint64_t record_size = format::record_header_size + format::message_fixed_size + data.size();
    // A message that would overflow the chunk starts the next one; one larger than a whole chunk
    // thus gets a chunk of its own.
    if (!chunk_->records.empty() && chunk_->records.size() + record_size > options_.chunk_bytes) {
        if (auto status = flush_chunk(); !status) {
            ++lost_messages_;
            lost_bytes_ += data.size();
            return status;
        }
    }
    append_channel_records(channel_id);
    const std::uint64_t offset = chunk_->records.size();
    append_message(chunk_->records, channel_id, sequence, log_time, publish_time, data);
    chunk_->indexes[channel_id].emplace_back(log_time, offset);
    if (chunk_->message_count == 0 || log_time < chunk_->start_time)
        chunk_->start_time = log_time;
    if (chunk_->message_count == 0 || log_time > chunk_->end_time)
        chunk_->end_time = log_time;
    ++chunk_->message_count;
    chunk_->message_bytes += data.size();
    if (chunk_->records.size() >= options_.chunk_bytes)
        return flush_chunk();
    return proto::Ok{};
}

proto::Status Writer::flush_chunk() {
    if (failed())
        return proto::Error{error_};
    if (closed_)
        return proto::Error{"the MCAP file " + file_->path() + " is closed"};
    if (chunk_->records.empty())
        return proto::Ok{};
    OpenChunk& chunk = *chunk_;

    ChunkFields fields;
    fields.message_start_time = chunk.start_time;
    fields.message_end_time = chunk.end_time;
    fields.uncompressed_size = chunk.records.size();
    fields.uncompressed_crc = crc32(chunk.records);
    fields.records = chunk.records;
    proto::Bytes compressed;
    if (options_.compression == "zstd") {
        // Data that does not shrink (already compressed images, say) is stored as it is.
        if (zstd_compress(chunk.records, options_.zstd_level, compressed) &&
            compressed.size() < chunk.records.size()) {
            fields.compression = "zstd";
            fields.records = compressed;
        }
    }

    const std::uint64_t chunk_offset = end_;
    proto::Bytes block;
    append_chunk(block, fields);
    ChunkIndexEntry index;
    index.message_start_time = chunk.start_time;
    index.message_end_time = chunk.end_time;
    index.chunk_start_offset = chunk_offset;
    index.chunk_length = block.size();
    index.compression = fields.compression;
    index.compressed_size = fields.records.size();
    index.uncompressed_size = fields.uncompressed_size;
    for (const auto& [channel_id, entries] : chunk.indexes) {
        index.message_index_offsets[channel_id] = chunk_offset + block.size();
        append_message_index(block, channel_id, entries);
    }
    index.message_index_length = block.size() - index.chunk_length;

    const std::uint64_t index_size = chunk_index_record_size(chunk.indexes.size(), fields.compression.size());
    if (auto status = write_block(block, index_size); !status) {
        lose_open_chunk();
        return status;
    }
    chunk_indexes_.push_back(std::move(index));
    index_bytes_ += index_size;
    if (statistics_.message_count == 0 || chunk.start_time < statistics_.message_start_time)
        statistics_.message_start_time = chunk.start_time;
    if (statistics_.message_count == 0 || chunk.end_time > statistics_.message_end_time)
        statistics_.message_end_time = chunk.end_time;
    statistics_.message_count += chunk.message_count;
    for (const auto& [channel_id, entries] : chunk.indexes)
        statistics_.channel_message_counts[channel_id] += entries.size();
    ++statistics_.chunk_count;
    schemas_in_file_.insert(chunk.schemas_added.begin(), chunk.schemas_added.end());
    channels_in_file_.insert(chunk.channels_added.begin(), chunk.channels_added.end());
    chunk_ = std::make_unique<OpenChunk>();
    return proto::Ok{};
}

proto::Status Writer::write_metadata(const std::string& name, const StringMap& values) {
    if (closed_)
        return proto::Error{"the MCAP file " + file_->path() + " is closed"};
    if (failed())
        return proto::Error{error_};
    proto::Bytes block;
    append_metadata(block, Metadata{name, values});
    const std::uint64_t offset = end_;
    const std::uint64_t index_size = metadata_index_record_size(name.size());
    if (auto status = write_block(block, index_size); !status)
        return status;
    MetadataIndexEntry index;
    index.offset = offset;
    index.length = block.size();
    index.name = name;
    metadata_indexes_.push_back(std::move(index));
    index_bytes_ += index_size;
    ++statistics_.metadata_count;
    return proto::Ok{};
}

std::uint64_t Writer::summary_estimate() const {
    // Every schema and channel counts, written or not: an estimate may only err on the large side.
    std::uint64_t size = format::data_end_record_size + statistics_record_size(channels_.size()) +
                         index_bytes_ + 6 * (format::record_header_size + 17) + format::footer_and_magic_size;
    for (const auto& [id, schema] : schemas_)
        size += schema_record_size(schema);
    for (const auto& [id, channel] : channels_)
        size += channel_record_size(channel);
    return size;
}

proto::Status Writer::write_block(const proto::Bytes& block, std::uint64_t summary_growth) {
    const std::uint64_t offset = end_;
    // Space for this block and for everything close() would write after it is taken from the
    // file system first: when that fails, the block is not written, and close() still has room
    // to finish the file in the space the previous block reserved.
    if (reserve_supported_) {
        const std::uint64_t length = block.size() + summary_estimate() + summary_growth + reserve_margin;
        const int error_number = file_->reserve(offset, length);
        if (error_number == EOPNOTSUPP) {
            reserve_supported_ = false;  // e.g. tmpfs before Linux 3.5, some FUSE file systems
        } else if (is_disk_full(error_number)) {
            fail("disk full at offset " + std::to_string(offset), error_number);
            return proto::Error{error_};
        }
        // Any other refusal: write without a reserve this time and let the write tell.
    }
    const int error_number = file_->write_at(offset, block);
    written_high_ = std::max(written_high_, offset + block.size());
    if (error_number != 0) {
        fail((is_disk_full(error_number) ? "disk full at offset " : "write failed at offset ") +
                 std::to_string(offset),
             error_number);
        return proto::Error{error_};
    }
    data_crc_ = [&] {
        Crc32 crc(data_crc_);
        crc.update(block);
        return crc.value();
    }();
    end_ += block.size();
    return proto::Ok{};
}

void Writer::fail(const std::string& what, int error_number) {
    if (error_.empty())
        error_ = what + ": " + std::strerror(error_number);
}

void Writer::lose_open_chunk() {
    lost_messages_ += chunk_->message_count;
    lost_bytes_ += chunk_->message_bytes;
    chunk_ = std::make_unique<OpenChunk>();
}

proto::Status Writer::close(const Metadata* closing_note) {
    if (closed_)
        return file_valid_ ? proto::Status(proto::Ok{})
                           : proto::Status(proto::Error{"already closed: " + error_});
    if (!failed())
        (void)flush_chunk();  // a failure is recorded in error_ and the chunk counted lost
    else
        lose_open_chunk();
    closed_ = true;

    // After a failed write the bytes past end_ are garbage: the end of the file is written over
    // them from end_, in the space reserved for it. (Truncating first, as one might, would also
    // free that reserved space: file systems drop preallocated blocks past the new end.) A closing
    // note goes first, in the same reserve (its margin holds a small one), so that even a file
    // whose disk filled says why it ended.
    proto::Bytes note_block;
    if (closing_note) {
        append_metadata(note_block, *closing_note);
        MetadataIndexEntry index;
        index.offset = end_;
        index.length = note_block.size();
        index.name = closing_note->name;
        metadata_indexes_.push_back(std::move(index));
        index_bytes_ += metadata_index_record_size(closing_note->name.size());
        ++statistics_.metadata_count;
        Crc32 crc(data_crc_);
        crc.update(note_block);
        data_crc_ = crc.value();
    }
    const std::uint64_t data_end = end_ + note_block.size();
    proto::Bytes tail = note_block;
    const proto::Bytes finish = finalization(data_end);
    tail.insert(tail.end(), finish.begin(), finish.end());
    if (const int error_number = file_->write_at(end_, tail); error_number != 0) {
        fail("cannot finish the file at offset " + std::to_string(end_), error_number);
        return proto::Error{error_ + " (the file has no footer; readers will report it truncated)"};
    }
    end_ = data_end + finish.size();
    // Cutting the file at its end also gives back the reserved blocks past it. It matters only
    // when a failed write left bytes beyond the footer; otherwise a failure costs nothing.
    if (const int error_number = file_->truncate(end_); error_number != 0 && written_high_ > end_) {
        fail("cannot cut the file at offset " + std::to_string(end_), error_number);
        return proto::Error{error_};
    }
    if (const int error_number = file_->sync(); error_number != 0) {
        fail("cannot sync the file", error_number);
        return proto::Error{error_};
    }
    file_valid_ = true;
    if (failed()) {
        return proto::Error{error_ + "; " + file_->path() + " was closed valid without " +
                            std::to_string(lost_messages_) + " messages"};
    }
    return proto::Ok{};
}

proto::Bytes Writer::finalization(std::uint64_t data_end) const {
    proto::Bytes out;
    append_data_end(out, data_crc_);
    const std::size_t summary_start = out.size();
    FooterFields footer;
    if (options_.write_summary) {
        // Records grouped by opcode, each group then located by a SummaryOffset record.
        std::vector<std::tuple<format::Opcode, std::size_t, std::size_t>> groups;
        const auto group = [&](format::Opcode opcode, const auto& fill) {
            const std::size_t start = out.size();
            fill();
            if (out.size() > start)
                groups.emplace_back(opcode, start, out.size() - start);
        };
        // Only schemas and channels whose records reached the data section: after a failure the
        // others are in no message of the file, and were never counted in the reserve.
        group(format::Opcode::schema, [&] {
            for (const std::uint16_t id : schemas_in_file_)
                append_schema(out, schemas_.at(id));
        });
        group(format::Opcode::channel, [&] {
            for (const std::uint16_t id : channels_in_file_)
                append_channel(out, channels_.at(id));
        });
        group(format::Opcode::statistics, [&] {
            Statistics statistics = statistics_;
            statistics.schema_count = static_cast<std::uint16_t>(schemas_in_file_.size());
            statistics.channel_count = static_cast<std::uint32_t>(channels_in_file_.size());
            append_statistics(out, statistics);
        });
        group(format::Opcode::chunk_index, [&] {
            for (const auto& index : chunk_indexes_)
                append_chunk_index(out, index);
        });
        group(format::Opcode::metadata_index, [&] {
            for (const auto& index : metadata_indexes_)
                append_metadata_index(out, index);
        });
        const std::size_t offsets_start = out.size();
        for (const auto& [opcode, start, length] : groups)
            append_summary_offset(out, static_cast<std::uint8_t>(opcode), data_end + start, length);
        footer.summary_start = data_end + summary_start;
        footer.summary_offset_start = data_end + offsets_start;
    }
    const std::size_t footer_start = out.size();
    append_footer(out, footer);
    if (options_.write_summary) {
        // The summary CRC covers the summary, the summary offsets and the footer up to the CRC.
        const std::size_t crc_at = footer_start + format::record_header_size + 16;
        const std::uint32_t crc = crc32(proto::ByteView(out).subspan(summary_start, crc_at - summary_start));
        for (std::size_t i = 0; i < 4; ++i)
            out[crc_at + i] = static_cast<std::uint8_t>(crc >> (8 * i));
    }
    out.insert(out.end(), format::magic.begin(), format::magic.end());
    return out;
}

}  // namespace plexus::mcap
