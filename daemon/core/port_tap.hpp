#pragma once
// Threading: the daemon's one thread (the tap is called from Inlet, which runs there), never with
// the port's arbiter lock held.

#include <cstdint>

#include "message.hpp"

namespace plexus::daemon {

class Inlet;

/// What became of one message that reached a port.
struct TapDecision {
    enum class Outcome : std::uint8_t {
        delivered,   ///< handed to the port's reader queue
        accept,      ///< dropped by a recv-side monitor (accept, or a failure with the drop policy)
        constraint,  ///< refused by the arbitration: the connection's constraint was false
        priority,    ///< refused by the arbitration: another connection won the stimulation
        auxiliary,   ///< an auxiliary connection: it stimulated, it never delivers
    };
    Outcome outcome = Outcome::delivered;
    /// The arbitration clock (seconds) when the monitors began on the message and when it was
    /// decided; 0 when unknown (a run of a batch passed unchanged, or decided before the tap).
    double monitor_time = 0;
    double decision_time = 0;
    /// Older messages the port's `latest` queue let go to make room for this one.
    std::uint64_t queue_dropped = 0;
};

/// Watches a port: every message that reaches it on each of its connections, and what the
/// monitors and the arbitration decided for it. A recording is one (record/recorder.hpp); the
/// port holds at most one tap, and with none the data path costs a null test per message.
class PortTap {
public:
    virtual ~PortTap() = default;
    /// `message` (one record, or a batch of records, as it arrived) reached the port on
    /// `inlet`'s connection.
    virtual void arrived(const Inlet& inlet, const Message& message) = 0;
    /// What became of messages that arrived earlier on `inlet`, in their order of arrival.
    /// `message` is the record (possibly rewritten by a monitor), or a batch whose records were
    /// all delivered.
    virtual void decided(const Inlet& inlet, const Message& message, const TapDecision& decision) = 0;
};

}  // namespace plexus::daemon
