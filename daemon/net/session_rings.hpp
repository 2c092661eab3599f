#pragma once
// Threading: one io_context thread; one reader and one writer coroutine at a time.
//
// The daemon's end of a client's shared-memory rings (proto/rings.hpp, PROTOCOL.md "Rings"): the
// region holding both rings, mapped read-write, and the four wake-ups by which each side wakes the
// other. The client may write anything into the region at any time: what is read of its
// positions is checked by the RingReader/RingWriter, and bytes are copied out before they are
// decoded.
//
// The client may do anything with the descriptors it was given, too. An eventfd is one open file
// description in both processes, so its O_NONBLOCK is the client's to clear (fcntl): a blocking
// read of ours on a counter the client emptied first, or a write of ours on a counter it filled to
// 2^64 - 2, would then hang the daemon's one thread, and every session with it. So the wake-ups
// the client signals are eventfds that we read with RWF_NOWAIT (never blocking, whatever the
// flags say), and those we signal are pipes whose write end is ours alone (O_NONBLOCK, never sent).
// We keep a copy of each pipe's read end while the session lasts: a write of ours never meets a
// pipe without a reader (no SIGPIPE, whatever the client closes).

#include <sys/uio.h>

#include <array>
#include <memory>
#include <vector>

#include "asio.hpp"
#include "plexus/proto/bytes.hpp"
#include "plexus/proto/rings.hpp"

namespace plexus::daemon {

class SessionRings {
public:
    /// A region with two rings of `ring_bytes` each (a power of two) and its eventfds.
    static proto::Result<std::unique_ptr<SessionRings>> create(asio::any_io_executor executor,
                                                               std::size_t ring_bytes);
    ~SessionRings();
    SessionRings(const SessionRings&) = delete;
    SessionRings& operator=(const SessionRings&) = delete;

    /// The descriptors the client gets with the `rings` answer, in proto::RingDescriptor order.
    std::vector<int> client_descriptors() const;
    std::size_t ring_bytes() const { return layout_.ring_bytes; }
    std::size_t region_bytes() const { return layout_.region_size(); }

    /// Copies what the client wrote (at least one byte) into `room`, waiting when there is none;
    /// 0 once the client closed its socket and the ring is empty (its end of stream); an Error when
    /// the rings were closed or the client's positions are impossible.
    Task<proto::Result<std::size_t>> read_some(asio::mutable_buffer room);
    /// Writes all of `buffers` into the ring to the client, waiting for room when it is full.
    Task<proto::Status> write(const std::vector<asio::const_buffer>& buffers);
    /// Ends the waits (they return an Error); nothing is read or written after.
    void close();
    /// Keeps looking at an empty ring this long after its last bytes before sleeping on it.
    void set_spin(std::chrono::microseconds spin) { spin_ = spin; }
    /// The client closed its socket: what it wrote before is still read, then read_some gives 0.
    void peer_closed();

    /// Wake-ups sent to the client and waits of ours that slept (for stats).
    std::uint64_t wakes_sent() const { return wakes_sent_; }
    std::uint64_t sleeps() const { return sleeps_; }
    /// The client wrote an impossible position (read_some or write failed because of it): it broke
    /// the protocol, which a session counts.
    bool peer_lied() const { return peer_lied_; }

private:
    explicit SessionRings(asio::any_io_executor executor);
    /// Signals the client through the write end of one of its pipes.
    void signal(int fd);
    /// Waits until `wait` is readable (the client signalled it), then empties it.
    Task<bool> sleep_on(asio::posix::stream_descriptor& wait);
    /// With a spin set and bytes lately: looks at the ring again from posted handlers (the other
    /// sessions run between two looks) until bytes come or the spin is over; true when they came.
    Task<bool> spin_for_bytes();

    proto::RingLayout layout_;
    int region_fd_ = -1;
    std::uint8_t* region_ = nullptr;
    std::array<int, proto::ring_descriptors> fds_{-1, -1, -1, -1, -1};  ///< as the client gets them
    asio::posix::stream_descriptor data_wait_;   ///< to_daemon_data: bytes from the client
    asio::posix::stream_descriptor space_wait_;  ///< to_client_space: room to write to the client
    int signal_client_data_ = -1;                ///< the write end of to_client_data's pipe
    int signal_client_space_ = -1;               ///< the write end of to_daemon_space's pipe
    proto::RingReader from_client_;
    proto::RingWriter to_client_;
    std::vector<iovec> pieces_;
    bool closed_ = false;
    bool peer_closed_ = false;
    bool peer_lied_ = false;
    std::chrono::microseconds spin_{0};
    std::chrono::steady_clock::time_point last_bytes_{};  ///< when the client's ring last had bytes
    std::uint64_t wakes_sent_ = 0;
    std::uint64_t sleeps_ = 0;
};

}  // namespace plexus::daemon
