#pragma once
// Threading: submit(), in_flight() and the results run on the daemon's one thread; what the filter
// does with a message in between may run on another thread (the monitors' workers).
//
// How core/ sees a connection's monitors without knowing about Lua or threads: a stage that takes
// the messages of one connection side in order and hands back, later and in the same order, what
// became of each. daemon/monitor/stage.hpp implements it.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "../arbitration/arbiter.hpp"
#include "message.hpp"

namespace plexus::daemon {

/// What became of one message in a filter.
enum class FilterVerdict : std::uint8_t {
    pass,     ///< go on, `message` possibly rewritten
    dropped,  ///< a monitor dropped it (accept, or a failure with the drop policy)
    refused,  ///< passed the monitors, refused by the input port's arbitration (counted there)
};

struct Filtered {
    Message message;  ///< a batch only for a run of records passed unchanged
    FilterVerdict verdict = FilterVerdict::pass;
    /// With `refused`: why the arbitration refused it.
    arbitration::Arbiter::Verdict arbitration = arbitration::Arbiter::Verdict::deliver;
    /// Only while the port's decisions are watched (Arbiter::watched), else 0: the arbitration
    /// clock when the monitors began on the message and when it was decided, so that a replay can
    /// run both steps at the same instants (`plexus what-if`).
    double monitor_time = 0;
    double decision_time = 0;
};

/// The end of the connection the filter reports to, on the daemon's thread.
class FilterClient {
public:
    virtual ~FilterClient() = default;
    /// The verdicts of messages submitted earlier, in submission order.
    virtual void filtered(std::vector<Filtered>& results) = 0;
};

class MessageFilter {
public:
    virtual ~MessageFilter() = default;
    /// Hands a message or a batch over; the verdicts come back through the client (a batch's
    /// records one by one, or in runs of records passed unchanged).
    virtual void submit(const Message& message) = 0;
    /// Submitted, verdict not yet handed back: they still count against the destination's room.
    virtual std::size_t in_flight() const = 0;
    /// How many more it takes before the filter holds as many as it may; 0 means full.
    virtual std::size_t room() const = 0;
    /// The connection is going: the monitors are let go (on their own thread), nothing more is
    /// reported.
    virtual void close() = 0;
    /// True when some monitor here looks at the answers to calls (PortMonitor.reply).
    virtual bool sees_replies() const { return false; }
    /// Passes the answer to a call back through the monitors (in the reverse order of its
    /// request); `done` runs on the daemon's thread with the answer as they left it (or as it was,
    /// when the filter closed meanwhile).
    virtual void reply(Message answer, std::function<void(Message)> done) { done(std::move(answer)); }
};

/// Room left in a destination after the messages still in a filter on their way to it.
inline std::size_t room_after(std::size_t room, const MessageFilter* filter) {
    if (!filter)
        return room;
    const std::size_t in_flight = filter->in_flight();
    const std::size_t left = room > in_flight ? room - in_flight : 0;
    const std::size_t filter_room = filter->room();
    return left < filter_room ? left : filter_room;
}

}  // namespace plexus::daemon
