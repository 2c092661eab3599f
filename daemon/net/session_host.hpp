#pragma once
// Threading: the thread of the session that calls it (`--threads`: net/shards.hpp).
//
// What a client's session needs of the daemon that hosts it, and nothing more: net/ does not
// include the daemon (STYLE.md, "Two imports run the wrong way"). The daemon implements it.

#include <chrono>
#include <cstdint>
#include <memory>

#include "asio.hpp"
#include "daemon_counters.hpp"
#include "net_config.hpp"
#include "plexus/proto/control.hpp"
#include "signal.hpp"

namespace plexus::daemon {

class CallTable;
class Session;

class SessionHost {
public:
    virtual const NetConfig& config() const = 0;
    virtual DaemonCounters& counters() = 0;
    /// Answers a control request of `session` (the control plane).
    virtual Task<proto::Reply> handle_request(std::shared_ptr<Session> session, proto::Request request) = 0;
    /// The session with this id, if it is still open (a reader's, for shared memory).
    virtual std::shared_ptr<Session> session(std::uint64_t id) const = 0;
    /// A writer on this thread is about to look for room downstream, and to wait if there is none:
    /// from now on room appearing on another thread wakes it (call before looking).
    virtual void expect_space() = 0;
    /// Waits at most `timeout` for room downstream, on this thread; true if woken.
    virtual Task<bool> wait_for_space(std::chrono::steady_clock::duration timeout) = 0;
    /// Room appeared (a session's outbox drained): wakes writers held back.
    virtual void notify_space() = 0;
    /// The control thread's executor (`--threads`): where a session on a data thread has its
    /// requests, calls and answers served.
    virtual asio::any_io_executor control_executor() = 0;
    virtual void session_closed(Session& session) = 0;
    /// The daemon's table of calls in progress (request/reply).
    virtual CallTable& calls() = 0;

protected:
    ~SessionHost() = default;
};

}  // namespace plexus::daemon
