#pragma once
// Threading: one thread receives and any number send (each under the send buffer's mutex);
// shutdown() may be called from any thread. The socket itself holds no lock (client/src/LOCK_ORDER.md).
//
// The stream socket to the daemon (Unix) or to a name server (TCP): connecting, receiving with the
// descriptors that come attached to the bytes, and gathering sends. It knows bytes and descriptors,
// not frames or ports; Connection's receiver and SendBuffer give the bytes their meaning.

#include <sys/socket.h>
#include <sys/uio.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>

#include "tls_channel.hpp"

namespace plexus::detail {

class ClientRings;

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

/// Receives up to `room` bytes into `at` with recvmsg (`flags` as recvmsg's) and appends the
/// descriptors (SCM_RIGHTS) that came with them to `fds`: shared-memory regions arrive so, and a
/// recv would close them unseen. Returns recvmsg's result; `cut_off` is set when some descriptors
/// were cut off (MSG_CTRUNC: more came than one receive holds).
ssize_t receive_with_descriptors(int fd, std::uint8_t* at, std::size_t room, int flags, std::deque<int>& fds,
                                 bool& cut_off);

/// A connected stream socket, closed with the object.
class FrameSocket {
public:
    /// Connects to the Unix socket at `path`; the descriptor, or Error (refused) with what to do.
    static int connect_unix(const std::string& path);
    /// A TCP socket connected to HOST:PORT with TCP_NODELAY, hellos not yet exchanged.
    static int connect_tcp(const std::string& address);

    /// Takes ownership of the connected socket `fd`, and of `tls` when its bytes go through TLS.
    explicit FrameSocket(int fd, std::unique_ptr<TlsChannel> tls = nullptr);
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

    // Shared-memory rings (client_rings.hpp): once a direction moved to its ring, receive() or
    // send_some()/wait_writable() use the ring, and the socket carries only descriptors and the end.
    /// For the receiving thread, right after the daemon's `rings` answer.
    void receive_from_rings(std::shared_ptr<ClientRings> rings) { in_rings_ = std::move(rings); }
    /// For a sender, under SendBuffer's mutex, once the rings are there.
    void send_into_rings(std::shared_ptr<ClientRings> rings) { out_rings_ = std::move(rings); }
    bool receives_from_rings() const { return in_rings_ != nullptr; }
    /// With rings: waits up to `timeout_ms` for a descriptor the daemon sent ahead of a frame that
    /// names it (it is on its way: the frame came after it); false when none came.
    bool await_descriptor(std::deque<int>& fds, int timeout_ms);

private:
    /// receive() through TLS: waits (with poll, the socket being non-blocking) as a blocking
    /// receive would.
    SocketReceived receive_tls(std::uint8_t* at, std::size_t room, int flags);

    int fd_ = -1;
    std::unique_ptr<TlsChannel> tls_;               ///< set for an encrypted TCP link
    std::shared_ptr<ClientRings> in_rings_;         ///< the receiving thread's
    std::shared_ptr<ClientRings> out_rings_;        ///< the senders', under SendBuffer's mutex
    std::chrono::microseconds receive_timeout_{0};  ///< as SO_RCVTIMEO, for the ring
};

}  // namespace plexus::detail
