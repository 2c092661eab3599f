#pragma once
// Threading: one thread receives and any number send (each under the send buffer's mutex);
// shutdown() may be called from any thread. The socket itself holds no lock (client/src/LOCK_ORDER.md).
//
// The stream socket to the daemon (Unix) or to a name server (TCP): connecting, receiving with the
// descriptors that come attached to the bytes, and gathering sends. It knows bytes and descriptors,
// not frames or ports; Connection's receiver and SendBuffer give the bytes their meaning.

#include <sys/uio.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>

namespace plexus::detail {

/// What one receive() gave: bytes, nothing (EINTR, EAGAIN), or the end of the connection.
struct SocketReceived {
    std::size_t bytes = 0;
    std::optional<std::string> failure;  ///< set when the connection ended or failed: why
};

/// What one send_some() did: bytes taken (perhaps fewer than offered), a full socket, or a failure.
struct SocketSent {
    std::size_t bytes = 0;
    bool full = false;                   ///< nothing taken: the socket has no room now
    std::optional<std::string> failure;  ///< the connection failed: why
};

/// A connected stream socket, closed with the object.
class FrameSocket {
public:
    /// Connects to the Unix socket at `path`; the descriptor, or Error (refused) with what to do.
    static int connect_unix(const std::string& path);
    /// A TCP socket connected to HOST:PORT with TCP_NODELAY, hellos not yet exchanged.
    static int connect_tcp(const std::string& address);

    /// Takes ownership of the connected socket `fd`.
    explicit FrameSocket(int fd) : fd_(fd) {}
    ~FrameSocket();
    FrameSocket(const FrameSocket&) = delete;
    FrameSocket& operator=(const FrameSocket&) = delete;

    int native_handle() const { return fd_; }

    /// One recvmsg into [at, at + room), blocking unless `flags` has MSG_DONTWAIT. Descriptors
    /// that came with the bytes are appended to `fds` (the caller owns and closes them).
    SocketReceived receive(std::uint8_t* at, std::size_t room, std::deque<int>& fds, int flags = 0);
    /// One gathering sendmsg of `pieces`, never blocking.
    SocketSent send_some(const iovec* pieces, std::size_t count);
    /// Waits up to `timeout_ms` for room to send; false on a timeout (an error shows at the next send).
    bool wait_writable(int timeout_ms);
    /// Bounds how long a blocking receive() waits (SO_RCVTIMEO; it then gives nothing).
    void set_receive_timeout(std::chrono::microseconds timeout);
    /// Raises the kernel's send buffer (capped by net.core.wmem_max).
    void set_send_buffer(int bytes);
    /// Ends both directions: a receive blocked in another thread returns (as if the peer closed).
    void shutdown();

private:
    int fd_ = -1;
};

}  // namespace plexus::detail
