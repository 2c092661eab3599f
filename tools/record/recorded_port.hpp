#pragma once
// One port of a Plexus recording (proto/mcap/include/plexus/mcap/recording_layout.hpp), read back
// for an offline re-run: its connections with their carriers, every message that reached it in
// file order, and the decision the daemon recorded for each. Used by one thread.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "plexus/mcap/reader.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::record {

/// The clock note of a recording: one instant on the wall clock and on the arbitration clock.
struct RecordingClock {
    std::uint64_t started_unix_ns = 0;
    double started_clock = 0;  ///< seconds on the arbitration clock (the daemon's steady clock)

    /// The arbitration clock at a wall-clock instant (a message's log_time).
    double clock_of(std::uint64_t unix_ns) const {
        return started_clock + (static_cast<double>(unix_ns) - static_cast<double>(started_unix_ns)) / 1e9;
    }
    /// Seconds since the Unix epoch at an arbitration-clock instant: what PortMonitor.now() said.
    double unix_seconds_of(double clock) const {
        return static_cast<double>(started_unix_ns) / 1e9 + (clock - started_clock);
    }
};

/// A connection into the port, as the recording names it.
struct RecordedConnection {
    std::string source;
    std::string carrier;      ///< the full carrier text the connection was made with
    std::uint64_t order = 0;  ///< its place among the port's connections (ties go to the earliest)
};

/// What the daemon decided for one message.
struct RecordedDecision {
    std::string outcome;       ///< delivered, accept, constraint, priority or auxiliary
    double monitor_time = 0;   ///< arbitration clock when the monitors began; 0 = unknown
    double decision_time = 0;  ///< arbitration clock of Arbiter::admit; 0 = unknown
};

/// One message that reached the port.
struct RecordedMessage {
    std::size_t connection = 0;  ///< index into RecordedPort::connections
    std::uint64_t seq = 0;       ///< the writer's seq (its low 32 bits only when no decision names it)
    std::uint64_t log_time = 0;  ///< when it arrived, ns since the Unix epoch
    std::uint64_t publish_time = 0;
    proto::Bytes payload;  ///< the CBOR as sent; empty unless ReadOptions::wants_payload said so
    std::optional<RecordedDecision> decision;  ///< none: in flight at the end, or dropped unjudged
};

/// A recorded port, ready to re-run.
struct RecordedPort {
    std::string port;
    RecordingClock clock;
    std::vector<RecordedConnection> connections;  ///< by plexus.order, earliest first
    std::vector<RecordedMessage> messages;        ///< in file order (the order they arrived)
    std::uint64_t decisions_without_message = 0;  ///< their message arrived before the recording began
    std::uint64_t events = 0;                     ///< entries of the PORT#events channel
    bool complete = false;                        ///< the end note is there (the daemon closed the file)
};

struct ReadOptions {
    /// Whether the payloads of a connection's messages are kept (a monitor will read them); null: all.
    std::function<bool(const RecordedConnection& connection)> wants_payload;
};

/// The ports a recording holds (the topics of its message channels), sorted.
std::vector<std::string> recorded_ports(const mcap::Reader& reader);

/// Reads `port` from an opened recording. Errors: no clock note, the port is not in the recording,
/// a decision that is not the JSON the layout says, and the reader's own (which name the offset).
proto::Result<RecordedPort> read_recorded_port(const mcap::Reader& reader, const std::string& port,
                                               const ReadOptions& options = {});

}  // namespace plexus::record
