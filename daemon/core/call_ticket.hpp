#pragma once
// Threading: made and handed on on the daemon's thread; a copy of its Message may die on a monitor
// worker, so its end only posts work to the daemon's thread (CallTicket::~CallTicket).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

namespace plexus::daemon {

/// Where a ticket reports its end: the daemon's call table (net/call_table.hpp), known here only
/// by this, so that core/ has no sockets.
class CallRoutes {
public:
    /// The request of call `id` was dropped before it left this daemon. Any thread.
    virtual void dropped(std::uint64_t id, std::string reason) = 0;

protected:
    ~CallRoutes() = default;
};

/// What a request carries through this daemon (Message::call): the id of its entry in the
/// daemon's call table, and its deadline. Whoever writes the request onto a socket (to the server's
/// client, or on the link to the server's daemon) hands it on; a request dropped anywhere before
/// that (by a monitor's accept, a constraint, a full queue, a port that nobody serves) ends with its
/// last copy, and the ticket's end tells the table so: the caller gets a refusal at once, not a
/// timeout. No drop site has to remember calls.
class CallTicket {
public:
    using Clock = std::chrono::steady_clock;
    /// `routes` is told (on whatever thread the last copy ends) if the ticket ends without being
    /// handed on, with the reason.
    CallTicket(std::uint64_t id, Clock::time_point deadline, std::weak_ptr<CallRoutes> routes)
        : id_(id), deadline_(deadline), routes_(std::move(routes)) {}
    ~CallTicket() {
        if (handed_on_.load(std::memory_order_acquire))
            return;
        if (auto routes = routes_.lock())
            routes->dropped(id_, reason_.empty() ? std::string(default_reason) : reason_);
    }
    CallTicket(const CallTicket&) = delete;
    CallTicket& operator=(const CallTicket&) = delete;

    std::uint64_t id() const { return id_; }
    Clock::time_point deadline() const { return deadline_; }
    /// Milliseconds left, at least 1 while the deadline has not passed, 0 after.
    std::uint64_t timeout_left_ms(Clock::time_point now = Clock::now()) const {
        if (now >= deadline_)
            return 0;
        const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline_ - now).count();
        return static_cast<std::uint64_t>(left);
    }
    /// The request left this daemon on a socket: the table now waits for its answer.
    void hand_on() { handed_on_.store(true, std::memory_order_release); }
    /// Counts a port that passed the call on (Port::route_call); false past max_ports.
    bool pass_port() { return ++ports_passed_ <= max_ports; }
    static constexpr int max_ports = 8;
    /// Where the ticket reports; null once the daemon is going.
    std::shared_ptr<CallRoutes> routes() const { return routes_.lock(); }
    /// Why it is being dropped, said where that is known (the daemon's thread, before the drop).
    void set_drop_reason(std::string reason) { reason_ = std::move(reason); }

    static constexpr const char* default_reason =
        "dropped on the way to the server (by a monitor's accept, a constraint, arbitration or a full queue)";

private:
    std::uint64_t id_;
    Clock::time_point deadline_;
    std::weak_ptr<CallRoutes> routes_;
    std::atomic<bool> handed_on_{false};
    std::string reason_;
    int ports_passed_ = 0;
};

}  // namespace plexus::daemon
