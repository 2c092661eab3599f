#pragma once
// Threading: every member is safe from any thread. One mutex, beside Demux's and ShmRegions' (only
// ReadDemand's is taken while it is held, and no completion runs under it): client/src/LOCK_ORDER.md.
//
// The calls of one connection to the daemon (request/reply, PROTOCOL.md "Calls"): those this
// client made and waits to hear about, by id, and those that reached its served ports, by handle,
// waiting for a Service to take them. The receiving side fills it; nothing here calls back into
// the connection.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <string>

#include "plexus/client.hpp"
#include "plexus/proto/bytes.hpp"
#include "plexus/proto/call.hpp"
#include "read_demand.hpp"

namespace plexus::detail {

/// What became of a call this client made.
struct CallAnswer {
    proto::CallOutcome outcome = proto::CallOutcome::ok;
    proto::Bytes record;  ///< the reply's record, when ok
    std::string reason;   ///< otherwise
};

/// A call that reached one of this client's served ports.
struct IncomingCall {
    std::uint64_t id = 0;  ///< the daemon's: the answer carries it back
    std::uint64_t timeout_ms = 0;
    proto::Bytes record;
};

/// A record as the Received it carries (a message read, a call's request or answer); Error
/// (refused) when it does not decode.
Received received_of(proto::ByteView record);

class CallBook {
public:
    using Clock = std::chrono::steady_clock;
    using Completion = std::function<void(CallAnswer)>;

    /// Waits register with `demand` (which must outlive this), so that the socket is read for them.
    explicit CallBook(ReadDemand& demand) : demand_(demand) {}
    CallBook(const CallBook&) = delete;
    CallBook& operator=(const CallBook&) = delete;

    /// A call about to be sent: its id (0 when the connection is gone: `done` was told). `done`
    /// runs exactly once, on the thread that completes it (the receiving thread, or whoever fails
    /// it). The socket is read for it until its answer comes, or `deadline` (the daemon answers
    /// by then).
    std::uint64_t add(Completion done, Clock::time_point deadline);
    /// The answer to call `id` arrived; false when nobody waits for it any more.
    bool complete(std::uint64_t id, CallAnswer answer);
    /// Ends call `id` with `outcome` (a send that failed, a caller that stopped waiting).
    void fail(std::uint64_t id, proto::CallOutcome outcome, std::string reason);
    /// The connection is gone: every call waiting ends as lost, and no call is taken any more.
    void fail_all(const std::string& reason);
    /// Calls still waiting for their answer.
    std::size_t waiting() const;

    /// A call reached served port `handle`.
    void deliver(std::uint64_t handle, IncomingCall call);
    /// Moves the calls waiting for `handle` into `into`, waiting up to `deadline` for the first;
    /// false if none came (or the connection is gone, or stop() was called for the handle).
    bool take(std::uint64_t handle, Clock::time_point deadline, std::deque<IncomingCall>& into);
    /// Wakes whoever waits in take() for `handle` and keeps no more calls for it.
    void stop(std::uint64_t handle);

private:
    ReadDemand& demand_;
    mutable std::mutex mutex_;
    std::condition_variable arrived_;
    std::uint64_t next_id_ = 1;
    std::map<std::uint64_t, Completion> waiting_;
    std::map<std::uint64_t, std::deque<IncomingCall>> incoming_;
    std::set<std::uint64_t> stopped_;
    std::string gone_;  ///< set once the connection is gone
};

}  // namespace plexus::detail
