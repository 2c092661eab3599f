#pragma once
// Threading: a RingWriter is used by one thread at a time, a RingReader too; the two ends of one
// ring are in different processes and meet only through the ring's shared memory.
//
// Shared-memory rings between a client and its local daemon (PROTOCOL.md, "Rings"): after the
// hellos, a client may ask that the frames of its session travel through two byte rings in one
// shared region instead of the Unix socket, one ring each way. The rings carry the same frames,
// in the same encoding and order, as the socket would; the socket stays for what only it can do:
// passing descriptors, and telling each side that the other one is gone.
//
// Each ring is a single-producer, single-consumer byte ring. Its positions only grow (mod 2^64);
// the producer publishes `tail`, the consumer `head`, and each side keeps its own copy of the
// position it owns, never reading it back from shared memory: the other process may write
// anything there. What a side reads of the other's position is checked (a consumer never reads
// past what fits, a producer never writes past what was freed) and a lie is a broken session.
// Bytes are copied out of a ring before they are decoded, so a writer changing them later
// changes nothing.
//
// Wake-ups: a side that finds nothing to do says so in the ring (`reader_waiting`,
// `writer_waiting`) before it sleeps on a wake-up descriptor; the other side signals it only when
// the flag was set, and clears it (an exchange), so a busy stream costs no system call at all. The
// client signals eventfds, the daemon the write ends of pipes it keeps to itself (PROTOCOL.md,
// "Rings": nothing the client does with its descriptors can make a call of the daemon block).

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include <sys/uio.h>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

/// The positions and flags of one ring, each side's on a cache line of its own.
struct RingControl {
    alignas(64) std::atomic<std::uint64_t> tail;  ///< bytes ever written (the producer's)
    std::atomic<std::uint32_t> writer_waiting;    ///< the producer sleeps until the consumer frees room
    alignas(64) std::atomic<std::uint64_t> head;  ///< bytes ever read (the consumer's)
    std::atomic<std::uint32_t> reader_waiting;    ///< the consumer sleeps until the producer writes
};
static_assert(std::atomic<std::uint64_t>::is_always_lock_free &&
                  std::atomic<std::uint32_t>::is_always_lock_free,
              "ring positions are shared between processes: they must be lock-free");

/// Where things are in the shared region: one page of controls, then the two rings' bytes.
struct RingLayout {
    static constexpr std::size_t controls_size = 4096;
    static constexpr std::size_t to_daemon_control = 0;    ///< offset of the client -> daemon control
    static constexpr std::size_t to_client_control = 128;  ///< offset of the daemon -> client control
    static constexpr std::size_t default_ring_bytes = 512 * 1024;
    static constexpr std::size_t min_ring_bytes = 64 * 1024;
    static constexpr std::size_t max_ring_bytes = 16 * 1024 * 1024;

    std::size_t ring_bytes = default_ring_bytes;  ///< each ring's capacity, a power of two

    std::size_t region_size() const { return controls_size + 2 * ring_bytes; }
    std::size_t to_daemon_data() const { return controls_size; }
    std::size_t to_client_data() const { return controls_size + ring_bytes; }
    /// The capacity a client's wish becomes: a power of two within the bounds; 0 means the default.
    static std::size_t ring_bytes_for(std::uint64_t wanted);
};

/// The descriptors that come with a `rings` answer, in this order (SCM_RIGHTS).
enum RingDescriptor : std::size_t {
    ring_region = 0,      ///< the memfd of the whole region, read-write
    to_daemon_data = 1,   ///< eventfd: the daemon waits on it for bytes from the client
    to_daemon_space = 2,  ///< a pipe's read end: the client waits on it for room to write
    to_client_data = 3,   ///< a pipe's read end: the client waits on it for bytes from the daemon
    to_client_space = 4,  ///< eventfd: the daemon waits on it for room to write
    ring_descriptors = 5,
};

/// The producing end of one ring.
class RingWriter {
public:
    RingWriter() = default;
    RingWriter(RingControl* control, std::uint8_t* data, std::size_t capacity)
        : control_(control), data_(data), capacity_(capacity) {}
    RingWriter& operator=(const RingWriter& other) {
        control_ = other.control_;
        data_ = other.data_;
        capacity_ = other.capacity_;
        tail_.store(other.tail_.load(std::memory_order_relaxed), std::memory_order_relaxed);
        return *this;
    }

    /// Copies as much of `pieces` as there is room for and publishes it; the bytes taken, or
    /// nullopt when the consumer's position is impossible (a broken or hostile peer). `wake` is
    /// set when the consumer sleeps and must be signalled.
    std::optional<std::size_t> write_some(const iovec* pieces, std::size_t count, bool& wake);
    /// Room to write now; nullopt when the consumer's position is impossible.
    std::optional<std::size_t> room() const;
    /// Says that this end sleeps until there is room, then looks again: true when there is room
    /// now after all (the flag is cleared: do not sleep).
    bool prepare_to_wait();
    void done_waiting() { control_->writer_waiting.store(0, std::memory_order_relaxed); }
    std::size_t capacity() const { return capacity_; }

private:
    RingControl* control_ = nullptr;
    std::uint8_t* data_ = nullptr;
    std::size_t capacity_ = 0;
    /// Ours, never read back from shared memory. Atomic only so that a thread may ask for room
    /// (prepare_to_wait) while another writes: one process's threads, not the peer.
    std::atomic<std::uint64_t> tail_{0};
};

/// The consuming end of one ring.
class RingReader {
public:
    RingReader() = default;
    RingReader(RingControl* control, const std::uint8_t* data, std::size_t capacity)
        : control_(control), data_(data), capacity_(capacity) {}

    /// Copies up to `room` bytes into `at` and frees them in the ring; the bytes copied, or
    /// nullopt when the producer's position is impossible. `wake` is set when the producer
    /// sleeps waiting for room and must be signalled.
    std::optional<std::size_t> read_some(std::uint8_t* at, std::size_t room, bool& wake);
    /// Bytes waiting now; nullopt when the producer's position is impossible.
    std::optional<std::size_t> available() const;
    /// Says that this end sleeps until bytes come, then looks again: true when bytes are there
    /// after all (the flag is cleared: do not sleep).
    bool prepare_to_wait();
    void done_waiting() { control_->reader_waiting.store(0, std::memory_order_relaxed); }

private:
    RingControl* control_ = nullptr;
    const std::uint8_t* data_ = nullptr;
    std::size_t capacity_ = 0;
    std::uint64_t head_ = 0;  ///< ours: never read back from shared memory
};

/// The `rings` frame. Client -> daemon: `varint ring_bytes` (0: the daemon's default) asks for rings;
/// the client then sends nothing more on the socket. Daemon -> client: `varint ring_bytes |
/// string reason`: ring_bytes > 0 with the five descriptors attached, after which every frame of
/// the daemon comes through the ring; 0 with the reason when refused (both sides stay on the socket).
Bytes make_rings_request(std::uint64_t ring_bytes);
Result<std::uint64_t> decode_rings_request(ByteView fields);
struct RingsAnswer {
    std::uint64_t ring_bytes = 0;
    std::string reason;
};
Bytes make_rings_answer(const RingsAnswer& answer);
Result<RingsAnswer> decode_rings_answer(ByteView fields);

}  // namespace plexus::proto
