#include "plexus/recording.hpp"

#include <algorithm>
#include <set>

#include "plexus/mcap/reader.hpp"
#include "plexus/mcap/recording_layout.hpp"
#include "plexus/proto/cbor.hpp"

namespace plexus {

namespace layout = mcap::layout;

struct Recording::State {
    explicit State(mcap::Reader opened) : reader(std::move(opened)) {}
    mcap::Reader reader;
    std::string path;

    std::string metadata(std::string_view record, const std::string& key) const {
        for (const auto& entry : reader.metadata()) {
            if (entry.name == record) {
                auto found = entry.values.find(key);
                return found == entry.values.end() ? std::string{} : found->second;
            }
        }
        return {};
    }
    static std::string value_of(const mcap::Channel& channel, std::string_view key) {
        auto found = channel.metadata.find(std::string(key));
        return found == channel.metadata.end() ? std::string{} : found->second;
    }
    static bool carries_messages(const mcap::Channel& channel) {
        return value_of(channel, layout::kind_key) == layout::messages_kind;
    }
};

Value RecordedMessage::value() const {
    auto decoded = proto::decode_cbor_fast({payload.data(), payload.size()});
    if (!decoded)
        throw Error(ErrorCode::usage,
                    "a recorded payload of " + source + " is not CBOR: " + decoded.error().message);
    return std::move(*decoded);
}

Recording::Recording(std::unique_ptr<State> state) : state_(std::move(state)) {}
Recording::Recording(Recording&&) noexcept = default;
Recording& Recording::operator=(Recording&&) noexcept = default;
Recording::~Recording() = default;

Recording Recording::open(const std::string& path) {
    auto reader = mcap::Reader::open(path);
    if (!reader)
        throw Error(ErrorCode::refused, path + ": " + reader.error().message);
    auto state = std::make_unique<State>(std::move(*reader));
    state->path = path;
    bool plexus_recording = false;
    for (const auto& entry : state->reader.metadata())
        plexus_recording = plexus_recording || entry.name == layout::recording_metadata;
    if (!plexus_recording)
        throw Error(ErrorCode::refused, path + ": an MCAP file, but not a Plexus recording (no " +
                                            std::string(layout::recording_metadata) + " metadata)");
    return Recording(std::move(state));
}

std::vector<std::string> Recording::ports() const {
    std::vector<std::string> names;
    const auto listed = Value::parse(state_->metadata(layout::recording_metadata, "ports"), nullptr, false);
    if (listed.is_array()) {
        for (const auto& name : listed) {
            if (name.is_string())
                names.push_back(name.get<std::string>());
        }
    }
    return names;
}

std::vector<RecordedConnection> Recording::connections() const {
    std::vector<RecordedConnection> out;
    const auto& counts = state_->reader.statistics().channel_message_counts;
    for (const auto& [id, channel] : state_->reader.channels()) {
        if (!State::carries_messages(channel))
            continue;
        RecordedConnection connection{State::value_of(channel, layout::port_key),
                                      State::value_of(channel, layout::source_key),
                                      State::value_of(channel, layout::carrier_key), 0};
        if (auto found = counts.find(id); found != counts.end())
            connection.messages = found->second;
        out.push_back(std::move(connection));
    }
    return out;
}

std::string Recording::node() const {
    return state_->metadata(layout::recording_metadata, "node");
}
std::uint64_t Recording::message_count() const {
    std::uint64_t total = 0;
    for (const auto& connection : connections())
        total += connection.messages;
    return total;
}
std::uint64_t Recording::start_ns() const {
    return state_->reader.statistics().message_start_time;
}
std::uint64_t Recording::end_ns() const {
    return state_->reader.statistics().message_end_time;
}
std::uint64_t Recording::size_bytes() const {
    return state_->reader.file_size();
}
std::map<std::string, std::string> Recording::end_note() const {
    for (const auto& entry : state_->reader.metadata()) {
        if (entry.name == layout::end_metadata)
            return entry.values;
    }
    return {};
}

void Recording::for_each(const std::function<bool(const RecordedMessage&)>& visit,
                         const std::vector<std::string>& ports) const {
    std::set<std::uint16_t> wanted;
    for (const auto& [id, channel] : state_->reader.channels()) {
        if (!State::carries_messages(channel))
            continue;
        const std::string port = State::value_of(channel, layout::port_key);
        if (ports.empty() || std::find(ports.begin(), ports.end(), port) != ports.end())
            wanted.insert(id);
    }
    if (wanted.empty())
        return;
    RecordedMessage message;
    const auto& channels = state_->reader.channels();
    auto read = state_->reader.for_each_message(
        [&](const mcap::MessageView& view) {
            const auto& channel = channels.at(view.channel_id);
            message.port = State::value_of(channel, layout::port_key);
            message.source = State::value_of(channel, layout::source_key);
            message.sequence = view.sequence;
            message.sent_ns = view.publish_time;
            message.arrived_ns = view.log_time;
            message.payload.assign(view.data.begin(), view.data.end());
            return visit(message);
        },
        &wanted);
    if (!read)
        throw Error(ErrorCode::refused, state_->path + ": " + read.error().message);
}

std::vector<RecordedMessage> Recording::messages(const std::vector<std::string>& ports) const {
    std::vector<RecordedMessage> all;
    for_each(
        [&all](const RecordedMessage& message) {
            all.push_back(message);
            return true;
        },
        ports);
    return all;
}

}  // namespace plexus
