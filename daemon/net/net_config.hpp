#pragma once
// The part of the daemon's settings that net/ reads: frames, queues towards other daemons, the
// handshake, data threads, shared memory, the udp carrier and the deployment secret. The daemon's
// whole configuration (app/daemon_config.hpp) extends it, so net/ sees these and nothing of the
// layers above it.

#include <chrono>
#include <cstddef>
#include <optional>

#include "core/reader_queue.hpp"
#include "net/peer_limits.hpp"
#include "net/udp_config.hpp"
#include "plexus/proto/auth.hpp"
#include "plexus/proto/frame.hpp"

namespace plexus::daemon {

struct NetConfig {
    std::size_t max_frame = proto::default_max_frame;
    std::size_t link_capacity = 1024;  ///< messages queued towards another daemon per connection
    std::size_t queue_bytes = ReaderQueue::default_max_bytes;  ///< byte bound of every queue
    /// A peer (client, daemon, CLI) that has not said hello, and proved the secret when one is
    /// needed, this long after connecting is cut off (config `handshake_timeout_ms`).
    std::chrono::milliseconds handshake_timeout{10000};
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
    /// What one peer (a TCP peer's address, a local client's uid) may hold at once (config
    /// `peer_connections`, `peer_handshakes`, `peer_failed_proofs`).
    PeerLimitConfig peer_limits;
};

}  // namespace plexus::daemon
