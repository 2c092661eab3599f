#pragma once
// Reads an MCAP file (https://mcap.dev/spec) without loading it whole: the summary at open, then
// chunk by chunk. Every problem is an Error whose message starts with the byte offset it was found
// at ("offset 1234: chunk CRC mismatch"); no length field is trusted before it is checked against
// the file's size and the reader's limits. A Reader is used by one thread at a time.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "plexus/mcap/records.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::mcap {

class InputSource;

/// One message, as for_each_message hands it out; `data` is valid during the call only.
struct MessageView {
    std::uint16_t channel_id = 0;
    std::uint32_t sequence = 0;
    std::uint64_t log_time = 0;
    std::uint64_t publish_time = 0;
    proto::ByteView data;
};

/// An opened MCAP file: its summary in memory, its messages read on demand.
class Reader {
public:
    /// Opens the file at `path` and reads its footer and summary (or scans it when it has none).
    static proto::Result<Reader> open(const std::string& path);
    /// The same on bytes in memory (the fuzz target's way in).
    static proto::Result<Reader> open_bytes(proto::Bytes bytes);

    Reader(Reader&&) noexcept;
    Reader& operator=(Reader&&) noexcept;
    ~Reader();

    /// Channels by id.
    const std::map<std::uint16_t, Channel>& channels() const { return channels_; }
    /// Schemas by id.
    const std::map<std::uint16_t, Schema>& schemas() const { return schemas_; }
    /// Metadata records in file order.
    const std::vector<Metadata>& metadata() const { return metadata_; }
    /// The Statistics record (counted by a scan when the file has no summary).
    const Statistics& statistics() const { return statistics_; }
    /// Whether the file has a summary section (false: what is known came from a scan).
    bool has_summary() const { return has_summary_; }
    /// The Header's profile and library strings.
    const std::string& profile() const { return profile_; }
    const std::string& library() const { return library_; }
    /// The file's size in bytes.
    std::uint64_t file_size() const;
    /// Chunks in the file.
    std::uint32_t chunk_count() const { return statistics_.chunk_count; }

    /// Calls `visit` for each message in file order, only those of `channels` when given; stops
    /// when `visit` returns false. Each chunk is read and decompressed once, and its CRC checked; a
    /// full pass also checks the data section's CRC.
    proto::Status for_each_message(const std::function<bool(const MessageView&)>& visit,
                                   const std::set<std::uint16_t>* channels = nullptr) const;

private:
    explicit Reader(std::unique_ptr<InputSource> source);
    static proto::Result<Reader> open_source(std::unique_ptr<InputSource> source);
    proto::Status read_summary_records(std::uint64_t summary_start, proto::ByteView summary);
    proto::Status scan_for_summary();

    std::unique_ptr<InputSource> source_;
    std::string profile_;
    std::string library_;
    std::uint64_t data_begin_ = 0;  // just after the Header record
    std::uint64_t data_end_ = 0;    // the summary's start, or the footer's when there is none
    std::uint64_t footer_offset_ = 0;
    bool has_summary_ = false;
    std::map<std::uint16_t, Schema> schemas_;
    std::map<std::uint16_t, Channel> channels_;
    std::vector<Metadata> metadata_;
    Statistics statistics_;
    // Chunk offset -> the channels its message indexes name (empty: not indexed), to skip chunks
    // a channel filter does not want without decompressing them.
    std::map<std::uint64_t, std::set<std::uint16_t>> chunk_channels_;
};

}  // namespace plexus::mcap
