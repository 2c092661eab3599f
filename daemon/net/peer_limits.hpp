#pragma once
// Threading: any thread (a mutex; taken only when a peer connects, finishes its handshake, fails a
// proof or goes, never per message).
//
// What one peer may hold of the daemon at once. Without these a single host could open
// connections until the daemon ran out of descriptors, or try the secret on hundreds of
// connections in parallel (the one-second pause after a failed proof is per connection).
// A peer is what the daemon can tell apart: a TCP peer's IP address, a local client's uid.

#include <chrono>
#include <cstddef>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace plexus::daemon {

struct PeerLimitConfig {
    std::size_t connections = 1024;  ///< open at once (a link between daemons is one per connection)
    std::size_t handshakes = 128;    ///< of those, not through their handshake yet (a daemon that
                                     ///< restarts re-opens all its links to another at once)
    std::size_t failed_proofs = 10;  ///< failed proofs of the secret in a minute: then refused until
                                     ///< the oldest is a minute old
};

class PeerLimits : public std::enable_shared_from_this<PeerLimits> {
public:
    using Clock = std::chrono::steady_clock;
    enum class Refusal { none, connections, handshakes, failed_proofs };

    /// A connection admitted: counted until the ticket goes.
    class Ticket {
    public:
        Ticket(std::shared_ptr<PeerLimits> limits, std::string peer)
            : limits_(std::move(limits)), peer_(std::move(peer)) {}
        ~Ticket();
        Ticket(const Ticket&) = delete;
        Ticket& operator=(const Ticket&) = delete;
        /// The peer said hello (and proved the secret when one is needed).
        void handshake_done();
        /// The peer failed to prove the secret.
        void proof_failed(Clock::time_point now = Clock::now());
        const std::string& peer() const { return peer_; }

    private:
        std::shared_ptr<PeerLimits> limits_;
        std::string peer_;
        bool handshaking_ = true;
    };

    explicit PeerLimits(PeerLimitConfig config) : config_(config) {}

    /// A new connection from `peer`: a ticket if it is admitted, else what it would exceed.
    struct Admission {
        std::unique_ptr<Ticket> ticket;
        Refusal refusal = Refusal::none;
    };
    Admission admit(const std::string& peer, Clock::time_point now = Clock::now());

    /// "1024 connections open (peer_connections)": the limit a refusal hit, for the log.
    std::string explain(Refusal refusal) const;
    /// Logs a refused connection from `peer` (`who` starts the line: "" or "names: "): one line a
    /// second at most, saying how many were refused since the last one. A peer at its limit may
    /// keep trying as fast as it likes; the log must not grow as fast.
    void log_refusal(const std::string& who, const std::string& peer, Refusal refusal,
                     Clock::time_point now = Clock::now());
    /// Peers with something counted (open connections or recent failed proofs).
    std::size_t peers() const;

private:
    struct Peer {
        std::size_t open = 0;
        std::size_t handshaking = 0;
        std::deque<Clock::time_point> failures;  ///< within the last minute, at most failed_proofs
    };
    static constexpr auto failure_window = std::chrono::minutes(1);
    void handshake_done(const std::string& peer);
    void proof_failed(const std::string& peer, Clock::time_point now);
    void closed(const std::string& peer, bool handshaking);
    /// Drops failures older than the window, and the entry when nothing is left in it.
    void tidy(std::map<std::string, Peer>::iterator it, Clock::time_point now);

    const PeerLimitConfig config_;
    mutable std::mutex mutex_;
    std::map<std::string, Peer> peers_;
    Clock::time_point last_logged_{};
    std::uint64_t not_logged_ = 0;
};

}  // namespace plexus::daemon
