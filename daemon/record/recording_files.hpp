#pragma once
// Threading: the recorder's writer thread only.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "plexus/mcap/writer.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::daemon::record {

/// A connection into a recorded port, as its channel in the file describes it.
struct ConnectionInfo {
    std::string port;
    std::string source;
    std::string carrier;
    std::uint64_t order = 0;      ///< its place among the port's connections (ties go to the earliest)
    std::string quoted_source;    ///< `source` as a JSON string, for the decisions' text
    std::string channel_key;      ///< its messages' channel among the file's: port and source
    std::string decisions_topic;  ///< its port's decisions channel
};

/// The file (or, with a split size, the files) one recording writes: MCAP through mcap::Writer, laid
/// out as plexus/mcap/recording_layout.hpp says. Channels are declared in each file before their
/// first message, so every file of a split recording can be read alone.
class RecordingFiles {
public:
    struct Options {
        std::string path;               ///< the first file; later ones are PATH-STEM.N.mcap
        std::uint64_t split_bytes = 0;  ///< 0: one file
        std::string node;
        nlohmann::json ports = nlohmann::json::array();
        nlohmann::json connections = nlohmann::json::array();  ///< into them, at the start
        std::uint64_t started_unix_ns = 0;
        double started_clock = 0;
    };
    /// Creates the first file (never replacing one).
    static proto::Result<std::unique_ptr<RecordingFiles>> create(Options options);

    void message(const ConnectionInfo& connection, std::uint64_t seq, std::uint64_t unix_ns,
                 std::uint64_t sent_ns, proto::ByteView payload);
    /// A decision, as JSON text (the recorder writes it without building a json object).
    void decision(const ConnectionInfo& connection, std::uint64_t unix_ns, proto::ByteView text);
    void event(const std::string& port, std::uint64_t unix_ns, const nlohmann::json& entry);
    /// Writes a short chunk so that an idle recording reaches the disk.
    void flush();
    /// Writes the end note and closes the current file.
    void close(const nlohmann::json& end);

    std::uint64_t bytes() const;  ///< over every file so far
    const std::vector<std::string>& files() const { return files_; }
    /// The first write that failed ("disk full at offset ..."); "" while all is well.
    const std::string& error() const { return error_; }
    /// Records of any kind (messages, decisions, events) a failed write lost.
    std::uint64_t lost_records() const;
    std::uint64_t lost_bytes() const;
    /// The recorded ports' messages handed to the files, and those in them once written (a
    /// message handed but not kept was lost with a chunk the disk refused).
    std::uint64_t handed_messages() const { return handed_messages_; }
    std::uint64_t kept_messages() const;

private:
    explicit RecordingFiles(Options options) : options_(std::move(options)) {}
    proto::Status open_next();
    void split_if_due();
    std::uint16_t channel(std::string_view key, const std::string& topic, std::string_view encoding,
                          const std::function<mcap::StringMap()>& metadata);
    void write(std::uint16_t channel, std::uint32_t sequence, std::uint64_t log_time,
               std::uint64_t publish_time, proto::ByteView data);
    void note_failure();
    /// A decision or an event: JSON on the port's channel of that kind.
    void json_record(const std::string& port, const std::string& topic, std::string_view kind,
                     std::uint64_t unix_ns, proto::ByteView text);
    /// Counts what the current file holds and lost, and lets it go (closed).
    void let_go_of_writer();
    std::uint64_t kept_in_current() const;

    Options options_;
    std::unique_ptr<mcap::Writer> writer_;
    std::map<std::string, std::uint16_t, std::less<>> channels_;  ///< of the current file, by key
    std::set<std::uint16_t> message_channels_;  ///< of the current file: the ports' messages
    std::uint64_t handed_messages_ = 0;
    std::uint64_t closed_kept_messages_ = 0;
    std::vector<std::string> files_;
    std::uint64_t closed_bytes_ = 0;  ///< of the files already closed
    std::uint64_t closed_lost_messages_ = 0;
    std::uint64_t closed_lost_bytes_ = 0;
    std::string error_;
};

}  // namespace plexus::daemon::record
