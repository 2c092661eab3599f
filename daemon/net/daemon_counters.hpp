#pragma once
// The daemon-wide counters that `plexus stats` shows as "daemon": counted where they happen,
// mostly by the sessions of net/, one set per thread (net/shards.hpp) added up to be shown.

#include <cstdint>

namespace plexus::daemon {

/// Daemon-wide counters that `plexus stats` shows.
struct DaemonCounters {
    std::uint64_t sessions_accepted = 0;
    std::uint64_t accept_errors = 0;         ///< failed accepts (e.g. out of file descriptors)
    std::uint64_t protocol_errors = 0;       ///< peers cut off for breaking the protocol
    std::uint64_t dropped_unknown_port = 0;  ///< data frames for a handle that is not open
    std::uint64_t dropped_link_down = 0;     ///< messages queued to another daemon when the link died
    std::uint64_t shm_passed = 0;            ///< messages whose payload went to readers in shared memory
    std::uint64_t shm_copied = 0;     ///< written in shared memory, copied out for readers that needed it
    std::uint64_t auth_failures = 0;  ///< TCP peers that did not prove they hold the deployment secret
    std::uint64_t handshake_timeouts = 0;  ///< peers cut off for not completing their handshake in time
    std::uint64_t ring_sessions = 0;       ///< sessions that moved to shared-memory rings
    std::uint64_t rings_refused = 0;       ///< rings asked for and refused (off, not local, no memory)
    std::uint64_t peers_refused =
        0;  ///< connections refused at once: their peer was at a limit (peer_limits.hpp)
    /// Encrypted links cut off because a record failed its check: bytes altered, injected or
    /// replayed on the way.
    std::uint64_t tls_records_refused = 0;
    /// Requests refused by the permissions file (core/permissions.hpp).
    std::uint64_t permission_refusals = 0;

    /// Adds another thread's counters (`--threads`: each thread of the daemon keeps its own).
    DaemonCounters& operator+=(const DaemonCounters& other) {
        sessions_accepted += other.sessions_accepted;
        accept_errors += other.accept_errors;
        protocol_errors += other.protocol_errors;
        dropped_unknown_port += other.dropped_unknown_port;
        dropped_link_down += other.dropped_link_down;
        shm_passed += other.shm_passed;
        shm_copied += other.shm_copied;
        auth_failures += other.auth_failures;
        handshake_timeouts += other.handshake_timeouts;
        ring_sessions += other.ring_sessions;
        rings_refused += other.rings_refused;
        peers_refused += other.peers_refused;
        tls_records_refused += other.tls_records_refused;
        permission_refusals += other.permission_refusals;
        return *this;
    }
};

}  // namespace plexus::daemon
