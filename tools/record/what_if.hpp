#pragma once
// Re-runs a recorded port's arbitration and recv-side monitors offline, with the daemon's own
// libraries (arbitration/, monitor/), on the recorded messages at their recorded times, and
// compares each decision with the one the daemon recorded. With the recorded carriers the re-run
// reproduces the recording; with other carriers for some connections it tells which messages
// would have gone the other way. Used by one thread.
//
// How time is replayed: a ManualClock is the arbitration clock (event lifetimes, stimulation
// decay) and PortMonitor.now() reads it (as Unix seconds, through the recording's clock note).
// Each message is two steps, as in the daemon's MonitorStage::process: its monitors at its
// recorded monitor_time, its arbitration at its decision_time. All steps of all connections run
// in time order (ties in file order), so that one connection's events are set, or not yet, when
// another's message is decided, as they were.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "monitor/monitor_policy.hpp"
#include "recorded_port.hpp"

namespace plexus::record {

struct WhatIfOptions {
    /// Connections re-run with another carrier: source port -> full carrier text.
    std::map<std::string, std::string> carriers;
    /// Where the carriers' scripts (file.NAME) and compiled monitors (type.so) are found.
    std::vector<std::string> script_dirs;
    std::vector<std::string> monitor_lib_dirs;
    daemon::monitor::MonitorPolicy policy;
};

/// Why a message is not compared.
enum class Standing {
    compared,   ///< recorded and re-run decisions both count
    undecided,  ///< no recorded decision (in flight when the recording ended, or dropped unjudged)
    /// decided while stimulation from before the recording may still have counted, and the
    /// re-run with the recorded carriers does not reproduce it: the unrecorded past decided it
    warm_up,
};

/// One message's two decisions.
struct MessageDecision {
    std::size_t message = 0;  ///< index into RecordedPort::messages
    std::string source;
    std::uint64_t seq = 0;
    double time = 0;       ///< its decision, seconds from the recording's start
    std::string recorded;  ///< "" when undecided
    std::string what_if;   ///< "" when undecided (it is not re-run)
    Standing standing = Standing::compared;
    bool changed() const { return standing == Standing::compared && recorded != what_if; }
};

struct SourceSummary {
    std::string source;
    std::string carrier;         ///< the what-if carrier (the recorded one unless replaced)
    bool replaced = false;       ///< --carrier gave it another
    std::uint64_t messages = 0;  ///< compared
    std::uint64_t changed = 0;
    std::uint64_t recorded_delivered = 0;
    std::uint64_t what_if_delivered = 0;
};

struct WhatIfResult {
    std::vector<MessageDecision> decisions;  ///< every message, in file order
    std::uint64_t compared = 0;
    std::uint64_t changed = 0;
    std::uint64_t undecided = 0;
    std::uint64_t warm_up = 0;
    std::vector<SourceSummary> sources;  ///< in connection order
    /// Times the delivering source switched among compared messages (in decision order).
    std::uint64_t recorded_winner_changes = 0;
    std::uint64_t what_if_winner_changes = 0;
    double duration = 0;                  ///< seconds from the start to the last decision
    std::uint64_t script_errors = 0;      ///< failed callbacks of the re-run's monitors
    std::uint64_t publishes_ignored = 0;  ///< PortMonitor.publish calls (nothing is published offline)
    bool trig_ignored = false;            ///< a monitor asked for trig(): offline it is not called
};

/// Re-runs `port`. Errors (a --carrier for a source not in the recording, a carrier that does not
/// parse, a script that is missing or refuses, singular weights) name the connection.
proto::Result<WhatIfResult> what_if(const RecordedPort& port, const WhatIfOptions& options);

/// Whether a connection's monitors read payloads: those of `port` re-run with `options`.
bool needs_payloads(const std::string& carrier_text);

}  // namespace plexus::record
