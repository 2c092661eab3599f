#pragma once
// How a Plexus recording uses MCAP (docs/RECORDING.md, "What a recording holds"): written by the
// daemon's recorder (daemon/record/), read by `plexus record --info`, `plexus play`,
// `plexus what-if`, libplexus and Python. Spelled once here so that writer and readers agree.
//
//   one channel per connection into a recorded port:
//       topic = the port's name, message_encoding "cbor", no schema (CBOR describes itself);
//       metadata plexus.kind=messages, plexus.port, plexus.source, plexus.carrier, plexus.order
//       (the connection's place among the port's connections: ties in arbitration go to the
//       earliest), plexus.node;
//       each message: data = the payload exactly as the writer sent it (CBOR), sequence = the low
//       32 bits of the writer's seq, publish_time = the writer's clock (ns since the Unix epoch),
//       log_time = the daemon's clock when it arrived (ns since the Unix epoch).
//   one channel "PORT#decisions" per recorded port (json): what became of each message, in order
//       per connection: {"source", "seq", "outcome", "monitor_time", "decision_time",
//       "queue_dropped"?}; times on the arbitration clock (seconds, see plexus.recording).
//   one channel "PORT#events" per recorded port (json): {"op": "set"|"unset", "name", "by",
//       "lifetime"?, "time"?}, in the order the port's event container saw them.
//   metadata "plexus.recording": node, started_unix_ns and started_clock (the same instant on the
//       wall clock and on the arbitration clock: the clock note that lines up files of several
//       nodes), ports (JSON list), connections (JSON list of {"port", "source", "carrier",
//       "queue", "capacity"}: those into the recorded ports at the start), version.
//   metadata "plexus.recording.end": messages, decisions, events, lost_messages, lost_bytes,
//       reason (why the recording ended) — absent when the daemon died while recording.

#include <string>
#include <string_view>

namespace plexus::mcap::layout {

inline constexpr std::string_view kind_key = "plexus.kind";
inline constexpr std::string_view port_key = "plexus.port";
inline constexpr std::string_view source_key = "plexus.source";
inline constexpr std::string_view carrier_key = "plexus.carrier";
inline constexpr std::string_view order_key = "plexus.order";
inline constexpr std::string_view node_key = "plexus.node";

inline constexpr std::string_view messages_kind = "messages";
inline constexpr std::string_view decisions_kind = "decisions";
inline constexpr std::string_view events_kind = "events";

inline constexpr std::string_view message_encoding = "cbor";
inline constexpr std::string_view record_encoding = "json";

inline constexpr std::string_view recording_metadata = "plexus.recording";
inline constexpr std::string_view end_metadata = "plexus.recording.end";

inline std::string decisions_topic(const std::string& port) {
    return port + "#decisions";
}
inline std::string events_topic(const std::string& port) {
    return port + "#events";
}

/// The outcomes a decision names (core/port_tap.hpp's TapDecision::Outcome, as text).
inline constexpr std::string_view outcome_names[] = {"delivered", "accept", "constraint", "priority",
                                                     "auxiliary"};

}  // namespace plexus::mcap::layout
