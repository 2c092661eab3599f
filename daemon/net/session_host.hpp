#pragma once
// Threading: the daemon's thread, as the sessions that call it.
//
// What a client's session needs of the daemon that hosts it, and nothing more: net/ does not
// include the daemon (STYLE.md, "Two imports run the wrong way"). The daemon implements it.

#include <cstdint>
#include <memory>

#include "../daemon_config.hpp"
#include "asio.hpp"
#include "plexus/proto/control.hpp"
#include "signal.hpp"

namespace plexus::daemon {

class CallTable;
class Session;

class SessionHost {
public:
    virtual const DaemonConfig& config() const = 0;
    virtual DaemonCounters& counters() = 0;
    /// Answers a control request of `session` (the control plane).
    virtual Task<proto::Reply> handle_request(std::shared_ptr<Session> session, proto::Request request) = 0;
    /// The session with this id, if it is still open (a reader's, for shared memory).
    virtual std::shared_ptr<Session> session(std::uint64_t id) const = 0;
    /// Notified whenever room appears downstream: writers held back wait on it.
    virtual Signal& space() = 0;
    /// Room appeared (a session's outbox drained): wakes writers held back.
    virtual void notify_space() = 0;
    virtual void session_closed(Session& session) = 0;
    /// The daemon's table of calls in progress (request/reply).
    virtual CallTable& calls() = 0;

protected:
    ~SessionHost() = default;
};

}  // namespace plexus::daemon
