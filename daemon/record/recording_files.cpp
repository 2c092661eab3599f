#include "recording_files.hpp"

#include <spdlog/spdlog.h>

#include "plexus/mcap/recording_layout.hpp"

namespace plexus::daemon::record {

namespace layout = mcap::layout;
using nlohmann::json;

namespace {
/// PATH for the first file, PATH-STEM.N.mcap for the N-th after it.
std::string file_name(const std::string& path, std::size_t n) {
    if (n == 0)
        return path;
    const std::string suffix = ".mcap";
    std::string stem = path;
    if (stem.size() > suffix.size() && stem.compare(stem.size() - suffix.size(), suffix.size(), suffix) == 0)
        stem.resize(stem.size() - suffix.size());
    return stem + "." + std::to_string(n) + suffix;
}

proto::ByteView text_bytes(const std::string& text) {
    return {reinterpret_cast<const std::uint8_t*>(text.data()), text.size()};
}
}  // namespace

proto::Result<std::unique_ptr<RecordingFiles>> RecordingFiles::create(Options options) {
    std::unique_ptr<RecordingFiles> files(new RecordingFiles(std::move(options)));
    if (auto opened = files->open_next(); !opened)
        return opened.error();
    return files;
}

proto::Status RecordingFiles::open_next() {
    const std::string path = file_name(options_.path, files_.size());
    auto created = mcap::Writer::create(path);
    if (!created)
        return created.error();
    writer_ = std::move(*created);
    channels_.clear();
    message_channels_.clear();
    files_.push_back(path);
    mcap::StringMap note{{"node", options_.node},
                         {"started_unix_ns", std::to_string(options_.started_unix_ns)},
                         {"started_clock", json(options_.started_clock).dump()},
                         {"ports", options_.ports.dump()},
                         {"connections", options_.connections.dump()},
                         {"part", std::to_string(files_.size() - 1)},
                         {"version", "1"}};
    if (auto written = writer_->write_metadata(std::string(layout::recording_metadata), note); !written)
        note_failure();
    return proto::Ok{};
}

void RecordingFiles::note_failure() {
    if (error_.empty() && writer_ && writer_->failed()) {
        error_ = writer_->error();
        spdlog::error("recording {}: {}", files_.back(), error_);
    }
}

std::uint16_t RecordingFiles::channel(std::string_view key, const std::string& topic,
                                      std::string_view encoding,
                                      const std::function<mcap::StringMap()>& metadata) {
    // Looked up on every message: by a view, without building the key or the metadata.
    if (auto found = channels_.find(key); found != channels_.end())
        return found->second;
    auto described = metadata();
    described.emplace(std::string(layout::node_key), options_.node);
    auto added = writer_->add_channel(topic, std::string(encoding), std::move(described));
    const std::uint16_t id = added ? *added : 0;  // 0: out of ids; its messages are counted lost
    channels_.emplace(std::string(key), id);
    return id;
}

void RecordingFiles::write(std::uint16_t channel, std::uint32_t sequence, std::uint64_t log_time,
                           std::uint64_t publish_time, proto::ByteView data) {
    if (!writer_->write_message(channel, sequence, log_time, publish_time, data))
        note_failure();
    split_if_due();
}

void RecordingFiles::message(const ConnectionInfo& connection, std::uint64_t seq, std::uint64_t unix_ns,
                             std::uint64_t sent_ns, proto::ByteView payload) {
    const std::uint16_t id = channel(connection.channel_key, connection.port, layout::message_encoding, [&] {
        return mcap::StringMap{{std::string(layout::kind_key), std::string(layout::messages_kind)},
                               {std::string(layout::port_key), connection.port},
                               {std::string(layout::source_key), connection.source},
                               {std::string(layout::carrier_key), connection.carrier},
                               {std::string(layout::order_key), std::to_string(connection.order)}};
    });
    message_channels_.insert(id);
    ++handed_messages_;
    write(id, static_cast<std::uint32_t>(seq), unix_ns, sent_ns, payload);
}

void RecordingFiles::decision(const ConnectionInfo& connection, std::uint64_t unix_ns, proto::ByteView text) {
    json_record(connection.port, connection.decisions_topic, layout::decisions_kind, unix_ns, text);
}

void RecordingFiles::event(const std::string& port, std::uint64_t unix_ns, const json& entry) {
    const std::string text = entry.dump();
    json_record(port, layout::events_topic(port), layout::events_kind, unix_ns, text_bytes(text));
}

void RecordingFiles::json_record(const std::string& port, const std::string& topic, std::string_view kind,
                                 std::uint64_t unix_ns, proto::ByteView text) {
    const std::uint16_t id = channel(topic, topic, layout::record_encoding, [&] {
        return mcap::StringMap{{std::string(layout::kind_key), std::string(kind)},
                               {std::string(layout::port_key), port}};
    });
    write(id, 0, unix_ns, unix_ns, text);
}

void RecordingFiles::split_if_due() {
    if (options_.split_bytes == 0 || !error_.empty() || writer_->bytes_written() < options_.split_bytes)
        return;
    if (!writer_->close())
        note_failure();
    let_go_of_writer();
    if (auto opened = open_next(); !opened) {
        error_ = "cannot open the next file of the recording: " + opened.error().message;
        spdlog::error("recording: {}", error_);
    }
}

void RecordingFiles::flush() {
    if (writer_ && !writer_->flush_chunk())
        note_failure();
}

void RecordingFiles::close(const json& end) {
    if (!writer_)
        return;
    mcap::Metadata note{std::string(layout::end_metadata), {}};
    for (const auto& [key, value] : end.items())
        note.values.emplace(key, value.is_string() ? value.get<std::string>() : value.dump());
    if (!writer_->close(&note))
        note_failure();
    let_go_of_writer();
}

void RecordingFiles::let_go_of_writer() {
    closed_bytes_ += writer_->bytes_written();
    closed_lost_messages_ += writer_->lost_messages();
    closed_lost_bytes_ += writer_->lost_bytes();
    closed_kept_messages_ += kept_in_current();
    writer_.reset();
}

std::uint64_t RecordingFiles::kept_in_current() const {
    if (!writer_)
        return 0;
    std::uint64_t kept = 0;
    const auto& counts = writer_->statistics().channel_message_counts;
    for (const auto id : message_channels_) {
        if (auto found = counts.find(id); found != counts.end())
            kept += found->second;
    }
    return kept;
}

std::uint64_t RecordingFiles::kept_messages() const {
    return closed_kept_messages_ + kept_in_current();
}

std::uint64_t RecordingFiles::bytes() const {
    return closed_bytes_ + (writer_ ? writer_->bytes_written() : 0);
}
std::uint64_t RecordingFiles::lost_records() const {
    return closed_lost_messages_ + (writer_ ? writer_->lost_messages() : 0);
}
std::uint64_t RecordingFiles::lost_bytes() const {
    return closed_lost_bytes_ + (writer_ ? writer_->lost_bytes() : 0);
}

}  // namespace plexus::daemon::record
