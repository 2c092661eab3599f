#pragma once
// The daemon's settings and its daemon-wide counters: apart from daemon.hpp, so that the control
// plane (control/) reads them without seeing the daemon's accept loops and sessions.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/reader_queue.hpp"
#include "monitor/monitor_policy.hpp"
#include "net/udp_config.hpp"
#include "plexus/proto/auth.hpp"
#include "plexus/proto/endpoint.hpp"
#include "plexus/proto/frame.hpp"
#include "web/http_config.hpp"

namespace plexus::daemon {

struct DaemonConfig {
    proto::Endpoint names{"127.0.0.1", 10100};
    bool embedded_names = false;
    std::string names_state;  ///< state file of the embedded name server
    proto::Endpoint listen{"127.0.0.1", 0};
    /// The host other daemons reach this one at (--advertise); empty: the --listen host, or, when
    /// that is 0.0.0.0 or ::, the address the name server sees this daemon's session come from.
    std::string advertise;
    std::string socket_path;
    std::string node;
    std::vector<std::string> script_dirs;
    /// Directories of compiled monitors (type.so): the only places a plugin is loaded from.
    std::vector<std::string> monitor_lib_dirs;
    std::string ready_file;  ///< written (JSON: node, address, socket, names) once registered
    std::size_t max_frame = proto::default_max_frame;
    std::size_t default_capacity = 1024;  ///< reader queue length when a client does not say
    std::size_t link_capacity = 1024;     ///< messages queued towards another daemon per connection
    std::size_t queue_bytes = ReaderQueue::default_max_bytes;  ///< byte bound of every queue
    std::chrono::milliseconds names_grace{2000};
    /// A peer (client, daemon, CLI) that has not said hello, and proved the secret when one is
    /// needed, this long after connecting is cut off (config `handshake_timeout_ms`).
    std::chrono::milliseconds handshake_timeout{10000};
    monitor::MonitorPolicy monitors;  ///< memory cap, time budget, quarantine of every port monitor
    std::size_t monitor_threads = 0;  ///< worker threads for monitors; 0: one per core
    /// Threads that move data (`--threads`): 1, the control thread does everything; N > 1, N data
    /// threads beside it, local sessions pinned to them in turn (net/shards.hpp).
    std::size_t threads = 1;
    /// Least size of the shared-memory region a local client may get per port it writes large
    /// payloads through (a region holds at least four of the port's first large payload); 0 turns
    /// shared memory off. Small on purpose: the slots in use stay warm in the cache, and fewer
    /// messages wait in a region (8 MiB against 32: 1 MiB fan-out to 8 readers 5,365 against
    /// 3,993 deliveries/s, p50 under load 3.4 against 30 ms).
    std::size_t shm_region_bytes = 8u * 1024u * 1024u;
    /// Bytes of each of the two rings a local client's session may move to (PROTOCOL.md "Rings"):
    /// a power of two from 65536 to 16777216; 0 keeps every session on its socket.
    std::size_t shm_ring_bytes = 512u * 1024u;
    /// How long the daemon keeps looking at a busy client's empty ring before it sleeps on it (the
    /// client then need not wake it): 0 to 1000 us, default 0 (or PLEXUS_RING_SPIN_US). Only after
    /// traffic: a ring whose last bytes came longer ago than this never spins. Other sessions are
    /// served meanwhile (the look is a posted handler, not a loop), but the daemon's thread stays busy.
    std::chrono::microseconds ring_spin{0};
    /// Bound on the bytes of all regions together.
    std::size_t shm_total_bytes = 1024u * 1024u * 1024u;
    UdpConfig udp;  ///< the udp carrier: datagram size, largest message, reassembly bounds
    /// The deployment secret: every TCP peer must prove it holds it, and datagrams carry a MAC
    /// made with it. Without one the daemon only listens on loopback, unless `insecure`.
    std::optional<proto::Secret> secret;
    bool insecure = false;  ///< --insecure: listen beyond loopback without a secret (warned loudly)
    web::HttpConfig http;   ///< the web endpoint (--http); off unless it has an address
};

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
        return *this;
    }
};

}  // namespace plexus::daemon
