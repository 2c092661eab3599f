#pragma once
// Threading: receive() belongs to the receiving thread; send_some() is called under SendBuffer's
// mutex and wait_writable() by a sender or the backlog thread, perhaps both at once. The rings are
// one producer and one consumer each, and their positions and flags atomics; the one lock,
// writer_wait_, lets one thread at a time sleep on the ring to the daemon (a leaf:
// client/src/LOCK_ORDER.md).
//
// The client's end of its session's shared-memory rings (proto/rings.hpp, PROTOCOL.md "Rings"):
// frames to the daemon are copied into one ring, frames from it are copied out of the other, and
// each side signals the other (an eventfd, or a pipe the daemon writes into) only when it sleeps. The Unix
// socket stays for the descriptors of shared-memory regions (each comes with one byte, ahead of the frame
// that names it) and for the end of the connection.

#include <sys/uio.h>

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "frame_socket.hpp"
#include "plexus/proto/rings.hpp"

namespace plexus::detail {

class ClientRings {
public:
    /// Maps the rings from the descriptors of the daemon's `rings` answer (taken: closed with the
    /// object, or at once on failure); nullopt and `why` when they cannot be used.
    static std::shared_ptr<ClientRings> map(std::vector<int> fds, std::uint64_t ring_bytes, std::string& why);
    ~ClientRings();
    ClientRings(const ClientRings&) = delete;
    ClientRings& operator=(const ClientRings&) = delete;

    /// What the daemon wrote, up to `room` bytes, waiting up to `timeout` (0: for ever) unless
    /// `wait` is false. Reads the socket `socket_fd` too: descriptors it brings are appended to
    /// `fds`, and its end is the connection's end once the ring is empty.
    SocketReceived receive(std::uint8_t* at, std::size_t room, int socket_fd, std::deque<int>& fds,
                           std::chrono::microseconds timeout, bool wait);
    /// Copies what fits of `pieces` into the ring to the daemon, without waiting.
    SocketSent send_some(const iovec* pieces, std::size_t count);
    /// Waits up to `timeout_ms` for room in the ring to the daemon (or the socket's end).
    bool wait_writable(int socket_fd, int timeout_ms);
    /// Reads what waits on the socket without blocking: descriptors into `fds`; false at its end.
    bool drain_socket(int socket_fd, std::deque<int>& fds, std::optional<std::string>& failure);

private:
    ClientRings() = default;
    static void signal(int fd);
    static void empty_eventfd(int fd);

    proto::RingLayout layout_;
    std::uint8_t* region_ = nullptr;
    std::array<int, proto::ring_descriptors> fds_{-1, -1, -1, -1, -1};
    proto::RingWriter to_daemon_;
    /// Held by the thread that sleeps for room in to_daemon_. The ring has one `writer_waiting`
    /// flag: a second sleeper would clear it on waking while the first still sleeps, and the
    /// daemon, seeing no one asleep, would not signal (a lost wake-up: the writer slept its whole
    /// timeout, 100 ms, with room to write).
    std::mutex writer_wait_;
    proto::RingReader from_daemon_;
    bool socket_ended_ = false;  ///< the receiving thread's: the daemon closed its socket
    /// How long the receiving thread looks at an empty ring before it sleeps (PLEXUS_SPIN_US).
    std::chrono::nanoseconds spin_{0};
};

/// The daemon's answer to a `rings` request, handed from the receiving thread to the thread that
/// asked. Its mutex is a leaf, taken with nothing else held (LOCK_ORDER.md).
class RingsAnswerSlot {
public:
    struct Answer {
        std::shared_ptr<ClientRings> rings;  ///< null: refused
        std::string reason;
    };
    void put(Answer answer) {
        {
            std::lock_guard lock(mutex_);
            answer_ = std::move(answer);
        }
        changed_.notify_all();
    }
    /// The answer, or nullopt when none came by `deadline`.
    std::optional<Answer> wait(std::chrono::steady_clock::time_point deadline) {
        std::unique_lock lock(mutex_);
        changed_.wait_until(lock, deadline, [&] { return answer_.has_value(); });
        auto answer = std::move(answer_);
        answer_.reset();
        return answer;
    }

private:
    std::mutex mutex_;
    std::condition_variable changed_;
    std::optional<Answer> answer_;
};

}  // namespace plexus::detail
