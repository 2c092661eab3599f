#include "recorded_port.hpp"

#include <algorithm>
#include <charconv>
#include <deque>
#include <map>
#include <set>

#include <nlohmann/json.hpp>

#include "plexus/mcap/recording_layout.hpp"

namespace plexus::record {

namespace layout = mcap::layout;

namespace {

std::string value_of(const mcap::StringMap& map, std::string_view key) {
    const auto found = map.find(std::string(key));
    return found == map.end() ? std::string() : found->second;
}

std::optional<std::uint64_t> unsigned_of(const std::string& text) {
    std::uint64_t value = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc{} || end != text.data() + text.size())
        return std::nullopt;
    return value;
}

bool is_message_channel(const mcap::Channel& channel) {
    return value_of(channel.metadata, layout::kind_key) == layout::messages_kind;
}

proto::Result<RecordingClock> clock_note(const mcap::Reader& reader) {
    for (const auto& metadata : reader.metadata()) {
        if (metadata.name != layout::recording_metadata)
            continue;
        RecordingClock clock;
        const auto unix_ns = unsigned_of(value_of(metadata.values, "started_unix_ns"));
        const auto started =
            nlohmann::json::parse(value_of(metadata.values, "started_clock"), nullptr, false);
        if (!unix_ns || !started.is_number())
            return proto::Error{"the recording's clock note (metadata " +
                                std::string(layout::recording_metadata) +
                                ") has no usable started_unix_ns / started_clock"};
        clock.started_unix_ns = *unix_ns;
        clock.started_clock = started.get<double>();
        return clock;
    }
    return proto::Error{"not a Plexus recording: no metadata " + std::string(layout::recording_metadata)};
}

bool has_end_note(const mcap::Reader& reader) {
    return std::any_of(reader.metadata().begin(), reader.metadata().end(),
                       [](const mcap::Metadata& m) { return m.name == layout::end_metadata; });
}

/// A decision entry as the recorder writes it (recording_layout.hpp).
struct DecisionEntry {
    std::string source;
    std::uint64_t seq = 0;
    RecordedDecision decision;
};

proto::Result<DecisionEntry> decision_of(proto::ByteView data, std::uint64_t index) {
    const auto json = nlohmann::json::parse(data.begin(), data.end(), nullptr, false);
    const auto bad = [&](const std::string& why) {
        return proto::Error{"decision " + std::to_string(index) + " of the port: " + why};
    };
    if (!json.is_object())
        return bad("not a JSON object");
    DecisionEntry entry;
    const auto source = json.find("source");
    const auto seq = json.find("seq");
    const auto outcome = json.find("outcome");
    if (source == json.end() || !source->is_string() || seq == json.end() || !seq->is_number_unsigned() ||
        outcome == json.end() || !outcome->is_string())
        return bad("it lacks source, seq or outcome");
    entry.source = source->get<std::string>();
    entry.seq = seq->get<std::uint64_t>();
    entry.decision.outcome = outcome->get<std::string>();
    if (std::find(std::begin(layout::outcome_names), std::end(layout::outcome_names),
                  entry.decision.outcome) == std::end(layout::outcome_names))
        return bad("unknown outcome '" + entry.decision.outcome + "'");
    for (const auto& [key, target] : {std::pair{"monitor_time", &entry.decision.monitor_time},
                                      std::pair{"decision_time", &entry.decision.decision_time}}) {
        const auto found = json.find(key);
        if (found != json.end() && found->is_number())
            *target = found->get<double>();
    }
    return entry;
}

}  // namespace

std::vector<std::string> recorded_ports(const mcap::Reader& reader) {
    std::set<std::string> ports;
    for (const auto& [id, channel] : reader.channels()) {
        if (is_message_channel(channel))
            ports.insert(value_of(channel.metadata, layout::port_key));
    }
    return {ports.begin(), ports.end()};
}

proto::Result<RecordedPort> read_recorded_port(const mcap::Reader& reader, const std::string& port,
                                               const ReadOptions& options) {
    auto clock = clock_note(reader);
    if (!clock)
        return clock.error();
    RecordedPort recorded;
    recorded.port = port;
    recorded.clock = *clock;
    recorded.complete = has_end_note(reader);

    // Channels: one per connection, plus the port's decisions and events.
    std::map<std::uint16_t, std::size_t> connection_of;  // channel id -> index into connections
    std::set<std::uint16_t> wanted;
    std::uint16_t decisions_channel = 0;
    std::uint16_t events_channel = 0;
    std::vector<std::pair<RecordedConnection, std::uint16_t>> found;
    for (const auto& [id, channel] : reader.channels()) {
        const std::string kind = value_of(channel.metadata, layout::kind_key);
        if (value_of(channel.metadata, layout::port_key) != port)
            continue;
        if (kind == layout::messages_kind) {
            RecordedConnection connection{
                value_of(channel.metadata, layout::source_key),
                value_of(channel.metadata, layout::carrier_key),
                unsigned_of(value_of(channel.metadata, layout::order_key)).value_or(0)};
            found.emplace_back(std::move(connection), id);
        } else if (kind == layout::decisions_kind) {
            decisions_channel = id;
        } else if (kind == layout::events_kind) {
            events_channel = id;
        } else {
            continue;
        }
        wanted.insert(id);
    }
    if (found.empty()) {
        std::string known;
        for (const auto& name : recorded_ports(reader))
            known += (known.empty() ? "" : ", ") + name;
        return proto::Error{
            "port " + port + " is not in the recording" +
            (known.empty() ? std::string(" (it holds no messages)") : " (it holds " + known + ")")};
    }
    // Earliest connection first, as the arbiter's members; the source breaks equal orders (two
    // daemons' files merged) so that the order never depends on channel ids.
    std::stable_sort(found.begin(), found.end(), [](const auto& a, const auto& b) {
        return std::tie(a.first.order, a.first.source) < std::tie(b.first.order, b.first.source);
    });
    for (auto& [connection, id] : found) {
        connection_of[id] = recorded.connections.size();
        recorded.connections.push_back(std::move(connection));
    }

    // One pass in file order. A decision is written after its message (the tap sees the arrival
    // first), so it belongs to the oldest message of that (source, seq) still waiting for one.
    std::map<std::pair<std::string, std::uint32_t>, std::deque<std::size_t>> waiting;
    std::uint64_t decisions = 0;
    std::optional<proto::Error> failure;
    auto status = reader.for_each_message(
        [&](const mcap::MessageView& view) {
            if (view.channel_id == events_channel) {
                ++recorded.events;
                return true;
            }
            if (view.channel_id == decisions_channel) {
                auto entry = decision_of(view.data, decisions++);
                if (!entry) {
                    failure = entry.error();
                    return false;
                }
                auto queue = waiting.find({entry->source, static_cast<std::uint32_t>(entry->seq)});
                if (queue == waiting.end() || queue->second.empty()) {
                    ++recorded.decisions_without_message;
                    return true;
                }
                auto& message = recorded.messages[queue->second.front()];
                queue->second.pop_front();
                message.seq = entry->seq;  // the full seq; the channel kept its low 32 bits
                message.decision = std::move(entry->decision);
                return true;
            }
            const auto connection = connection_of.find(view.channel_id);
            if (connection == connection_of.end())
                return true;
            RecordedMessage message;
            message.connection = connection->second;
            message.seq = view.sequence;
            message.log_time = view.log_time;
            message.publish_time = view.publish_time;
            const auto& source = recorded.connections[connection->second].source;
            if (!options.wants_payload || options.wants_payload(recorded.connections[connection->second]))
                message.payload.assign(view.data.begin(), view.data.end());
            waiting[{source, view.sequence}].push_back(recorded.messages.size());
            recorded.messages.push_back(std::move(message));
            return true;
        },
        &wanted);
    if (failure)
        return *failure;
    if (!status)
        return status.error();
    return recorded;
}

}  // namespace plexus::record
