#pragma once
// Threading: the daemon's thread. A ticket that dies elsewhere posts its end here (ticket_for).
//
// Request/reply through this daemon (PROTOCOL.md, "Calls"). Every call that passes through keeps
// one entry here from the moment it arrives (from a caller's client, or on a link from the
// caller's daemon) until it is answered or failed: where its answer goes back (the socket it came
// on and the id it had there), where it went (the socket it left on), and its deadline. The
// answer comes back on the socket the call left on, and leaves on the socket it came on with the
// id it came with: hop by hop, along the path the request took. Every way a call can end without
// an answer ends here too, so that the caller is told, within its timeout and at once when it is
// known: a deadline passed (swept), the socket it left on closed (a server or a daemon gone, a
// link cut), the request dropped on the way (its ticket ended).

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include <nlohmann/json.hpp>

#include "../core/call_ticket.hpp"
#include "../core/message_filter.hpp"
#include "../core/port.hpp"
#include "asio.hpp"
#include "plexus/proto/call.hpp"

namespace plexus::daemon {

class FramedConnection;

/// How calls ended here, for `plexus stats` (the daemon's "calls" entry).
struct CallCounters {
    std::uint64_t started = 0;            ///< calls that entered this daemon
    std::uint64_t answered = 0;           ///< answers passed back (ok or failed by the server's handler)
    std::uint64_t refused = 0;            ///< not delivered: dropped on the way, no server, busy
    std::uint64_t busy = 0;               ///< of those: a port had max_calls_per_port outstanding
    std::uint64_t timed_out = 0;          ///< no answer by the deadline
    std::uint64_t lost = 0;               ///< the socket the call left on closed first
    std::uint64_t caller_gone = 0;        ///< answers (or failures) with nobody left to take them
    std::uint64_t late_answers = 0;       ///< answers after the call had timed out or failed
    std::uint64_t duplicate_answers = 0;  ///< a second answer to a call already answered
    std::uint64_t unknown_answers =
        0;  ///< answers to ids never seen, or from a socket the call did not go to
};

class CallTable final : public CallRoutes, public std::enable_shared_from_this<CallTable> {
public:
    using Clock = std::chrono::steady_clock;

    explicit CallTable(asio::any_io_executor executor) : executor_(std::move(executor)), timer_(executor_) {}

    /// Calls one port may have outstanding at once (as the caller's port, or as the server's): past
    /// it, a call is refused as busy rather than held, so that memory stays bounded.
    static constexpr std::uint64_t max_calls_per_port = 4096;

    /// A call arrived on `back` with id `back_id`, through `port`: its entry, and the ticket its
    /// message carries; null (nothing kept) when the port has max_calls_per_port outstanding.
    /// `reply_through`: the monitor stages here that the answer passes on its way back, in that
    /// order (those of the connection whose monitors have PortMonitor.reply; empty for none).
    std::shared_ptr<CallTicket> start(const std::shared_ptr<FramedConnection>& back, std::uint64_t back_id,
                                      Clock::time_point deadline, std::string what,
                                      const std::shared_ptr<Port>& port,
                                      std::vector<std::shared_ptr<MessageFilter>> reply_through = {});
    /// A call is refused before it entered the table (no server, busy, a bad port): the answer
    /// goes straight back on `back`.
    void refuse(FramedConnection& back, std::uint64_t back_id, std::string_view reason);
    /// The request of entry `id` left on `out`: its answer must come back on that socket.
    void handed_on(std::uint64_t id, const std::shared_ptr<FramedConnection>& out);
    /// An answer frame arrived on `from`.
    void answer(FramedConnection& from, const proto::AnswerView& answer);
    /// `connection` closed: the calls that left on it are lost, those that came on it have no caller.
    void closed(const FramedConnection& connection);
    /// A ticket ended before its request left (CallRoutes): the caller is refused now.
    void dropped(std::uint64_t id, std::string reason) override;

    /// Calls waiting for their answer now.
    std::size_t outstanding() const { return entries_.size(); }
    const CallCounters& counters() const { return counters_; }
    /// Adds "calls_outstanding" and the counters, each "calls_NAME", to the daemon's entry of
    /// `plexus stats` (flat, as /metrics reads it).
    void add_stats(nlohmann::json& daemon) const;

private:
    struct Entry {
        std::weak_ptr<FramedConnection> back;
        std::uint64_t back_id = 0;
        const FramedConnection* out = nullptr;  ///< compared only; the socket the request left on
        Clock::time_point deadline;
        std::string what;          ///< "/caller -> /server", for reasons
        std::weak_ptr<Port> port;  ///< whose calls_outstanding counts it
        std::vector<std::weak_ptr<MessageFilter>> reply_through;
    };
    /// Sends an ok answer back on `back` with id `back_id`, after the stages of `through`, one by one.
    static void pass_back(std::weak_ptr<FramedConnection> back, std::uint64_t back_id, Message answer,
                          std::vector<std::weak_ptr<MessageFilter>> through, std::size_t next);
    /// Ends entry `id` with a failure sent back to its caller.
    void fail(std::uint64_t id, proto::CallOutcome outcome, std::string_view reason);
    /// Sends a failure to `back` (if it is still there).
    void send_failure(const Entry& entry, proto::CallOutcome outcome, std::string_view reason);
    /// Forgets an entry, remembering for a while how it ended (to tell late from duplicate answers).
    void finish(std::uint64_t id, bool answered);
    void arm_timer();
    void sweep();

    asio::any_io_executor executor_;
    asio::steady_timer timer_;
    bool timer_armed_ = false;
    std::uint64_t next_id_ = 1;
    std::unordered_map<std::uint64_t, Entry> entries_;
    std::set<std::pair<Clock::time_point, std::uint64_t>> deadlines_;
    /// How recently finished calls ended, the oldest forgotten past a bound.
    struct Finished {
        bool answered = false;
        const FramedConnection* out = nullptr;  ///< only an answer from there is late or duplicate
    };
    std::unordered_map<std::uint64_t, Finished> finished_;
    std::deque<std::uint64_t> finished_order_;
    CallCounters counters_;
};

}  // namespace plexus::daemon
