#pragma once
// Writes an MCAP file (https://mcap.dev/spec): messages in zstd-compressed chunks with their
// message indexes, then a summary (schemas, channels, statistics, chunk and metadata indexes) so
// readers can seek. A full disk never leaves an unreadable file: see docs/RECORDING.md.
// Used by one thread.

#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "plexus/mcap/output_file.hpp"
#include "plexus/mcap/records.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::mcap {

/// How the writer lays out the file.
struct WriterOptions {
    std::uint64_t chunk_bytes =
        4 * 1024 * 1024;               ///< uncompressed bytes per chunk (a larger message gets its own)
    std::string compression = "zstd";  ///< "zstd" or "" (none)
    int zstd_level = 1;
    bool write_summary = true;  ///< false: a footer without summary (readers then scan the file)
    std::string profile;        ///< the Header's profile; "" for Plexus recordings
};

/// One MCAP file being written; close() finalizes it (the destructor does, if close() was not called).
class Writer {
public:
    /// Creates the file at `path` (never replacing one) and writes its magic and Header.
    static proto::Result<std::unique_ptr<Writer>> create(const std::string& path, WriterOptions options = {});
    /// The same on a file the caller made (tests hand in files that fail on purpose).
    static proto::Result<std::unique_ptr<Writer>> create_on(std::unique_ptr<OutputFile> file,
                                                            WriterOptions options = {});
    ~Writer();
    Writer(const Writer&) = delete;
    Writer& operator=(const Writer&) = delete;

    /// Registers a schema and returns its id (from 1); 0 once all 65535 ids are taken.
    std::uint16_t add_schema(const std::string& name, const std::string& encoding, proto::ByteView data);
    /// Registers a channel and returns its id (from 1); its record is written before its first message.
    proto::Result<std::uint16_t> add_channel(const std::string& topic, const std::string& message_encoding,
                                             StringMap metadata, std::uint16_t schema_id = 0);
    /// Adds a message to the current chunk (written when full). After a failure the message is counted lost.
    proto::Status write_message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                                std::uint64_t publish_time, proto::ByteView data);
    /// Writes a Metadata record (outside chunks, as the spec requires).
    proto::Status write_metadata(const std::string& name, const StringMap& values);
    /// Writes the current chunk now, however small, so that an idle recording still reaches the disk.
    proto::Status flush_chunk();
    /// Writes the current chunk, DataEnd, the summary, the footer and the closing magic. Fails when
    /// any message was lost; file_valid() then tells whether the file was still finalized.
    /// `closing_note`, when given, is written as a last Metadata record even after a failed write
    /// (into the space reserved for the end of the file), so that a file says why it ended.
    proto::Status close(const Metadata* closing_note = nullptr);

    /// Whether close() wrote a complete, readable file.
    bool file_valid() const { return file_valid_; }
    /// Whether a write failed (the file then receives no more messages); error() says why.
    bool failed() const { return !error_.empty(); }
    /// The first failure, e.g. "disk full at offset 1234: No space left on device"; "" if none.
    const std::string& error() const { return error_; }
    /// Messages accepted by write_message that will not be in the file.
    std::uint64_t lost_messages() const { return lost_messages_; }
    /// Payload bytes of those messages.
    std::uint64_t lost_bytes() const { return lost_bytes_; }
    /// Bytes written to the file so far (its data section, or the whole file after close()).
    std::uint64_t bytes_written() const { return end_; }
    /// Messages written to the file so far (not those still in the current chunk).
    std::uint64_t messages_written() const { return statistics_.message_count; }
    /// What the file holds so far (per channel too), as its Statistics record will say.
    const Statistics& statistics() const { return statistics_; }
    /// Chunks written so far.
    std::uint32_t chunks_written() const { return statistics_.chunk_count; }

private:
    struct ChunkIndexEntry;
    struct MetadataIndexEntry;
    struct OpenChunk;

    Writer(std::unique_ptr<OutputFile> file, WriterOptions options);
    proto::Status write_header();
    proto::Status write_block(const proto::Bytes& block, std::uint64_t summary_growth);
    void fail(const std::string& what, int error_number);
    void lose_open_chunk();
    void append_channel_records(std::uint16_t channel_id);
    std::uint64_t summary_estimate() const;
    proto::Bytes finalization(std::uint64_t data_end_offset) const;

    std::unique_ptr<OutputFile> file_;
    WriterOptions options_;
    std::uint64_t end_ = 0;           // end of the last good write
    std::uint64_t written_high_ = 0;  // furthest byte any write reached, good or not
    std::uint32_t data_crc_ = 0;      // CRC32 of [0, end_): DataEnd's
    bool reserve_supported_ = true;
    bool closed_ = false;
    bool file_valid_ = false;
    std::string error_;
    std::uint64_t lost_messages_ = 0;
    std::uint64_t lost_bytes_ = 0;

    std::map<std::uint16_t, Schema> schemas_;
    std::map<std::uint16_t, Channel> channels_;
    std::set<std::uint16_t> schemas_in_file_;   // their record is in a written chunk
    std::set<std::uint16_t> channels_in_file_;  // ditto
    std::unique_ptr<OpenChunk> chunk_;
    std::vector<ChunkIndexEntry> chunk_indexes_;
    std::vector<MetadataIndexEntry> metadata_indexes_;
    std::uint64_t index_bytes_ = 0;  // size of the chunk and metadata index records the summary will hold
    Statistics statistics_;
};

}  // namespace plexus::mcap
