#pragma once
// Threading: any number of threads; each call takes the channel's mutex, a leaf taken with at most
// SendBuffer's held, and never held while a thread waits for the socket (client/src/LOCK_ORDER.md).
//
// TLS 1.3 over a TCP socket to a name server or a remote daemon, keyed by the deployment secret
// (proto/tls_psk.hpp). FrameSocket reads and writes through it as it would through the socket;
// the socket is non-blocking from the handshake on, and FrameSocket waits for it with poll.

#include <sys/types.h>
#include <sys/uio.h>

#include <chrono>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "plexus/proto/auth.hpp"
#include "plexus/proto/identity.hpp"

struct ssl_st;

namespace plexus::detail {

class TlsChannel {
public:
    /// Runs the handshake as the connecting end on the connected socket `fd` (which it makes
    /// non-blocking), by `deadline`. Throws Error (refused, or timeout) saying why it failed.
    TlsChannel(int fd, const proto::Secret& secret, const std::string& address,
               std::chrono::steady_clock::time_point deadline);
    ~TlsChannel();
    TlsChannel(const TlsChannel&) = delete;
    TlsChannel& operator=(const TlsChannel&) = delete;

    /// Like recv with MSG_DONTWAIT: bytes (> 0), 0 at the end of the stream, or -1 with errno set
    /// (EAGAIN: nothing now; EPROTO: the stream broke, failure() says how).
    ssize_t receive(std::uint8_t* at, std::size_t room);
    /// Like sendmsg with MSG_DONTWAIT: bytes taken from `pieces` (at most a record's worth), or -1
    /// with errno set (EAGAIN: no room now; offer the same bytes again later).
    ssize_t send(const iovec* pieces, std::size_t count);
    /// Sends all of `bytes` and receives into `at`, waiting up to `deadline` (the hello exchange).
    void send_all(const std::uint8_t* bytes, std::size_t size,
                  std::chrono::steady_clock::time_point deadline);
    ssize_t receive_by(std::uint8_t* at, std::size_t room, std::chrono::steady_clock::time_point deadline);
    /// Why the last call that set EPROTO failed.
    std::string failure() const;
    /// With identities: what the peer's certificate names (checked in the handshake); else nullopt.
    std::optional<proto::Subject> peer_subject() const;

private:
    /// Maps an SSL call's result to recv's convention; `waits_for` gets POLLIN or POLLOUT.
    ssize_t outcome(int result, short* waits_for = nullptr);

    int fd_;
    ssl_st* ssl_ = nullptr;
    mutable std::mutex mutex_;
    std::vector<std::uint8_t> gathered_;  ///< small pieces joined into one record
    std::string failure_;
};

}  // namespace plexus::detail
