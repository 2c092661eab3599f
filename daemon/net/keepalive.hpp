#pragma once
// Threading: a function on a socket the caller owns.

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

namespace plexus::daemon {

/// A peer whose machine vanished (power, cable, Wi-Fi gone) must be noticed in seconds, not the
/// kernel's two hours (idle) or fifteen minutes (data unacknowledged), so that its name-server
/// registration and its links go as a dead process's do, and persistent connections are made
/// again once it is back. Keepalive probes start after 3 s of silence, every 1 s; TCP_USER_TIMEOUT
/// ends the connection once data has stayed unacknowledged, or probes unanswered, for 10 s. Not
/// less: a cable out for 5 s must heal without a reconnection (the retransmission due 6.2 s after
/// a cut would be cut off by a shorter timeout).
inline constexpr int peer_timeout_ms = 10'000;

inline void keep_alive(int fd) {
    const int on = 1;
    const int idle_seconds = 3;
    const int interval_seconds = 1;
    const int probes = 3;
    const int user_timeout_ms = peer_timeout_ms;
    ::setsockopt(fd, SOL_SOCKET, SO_KEEPALIVE, &on, sizeof on);
    ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPIDLE, &idle_seconds, sizeof idle_seconds);
    ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPINTVL, &interval_seconds, sizeof interval_seconds);
    ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPCNT, &probes, sizeof probes);
    ::setsockopt(fd, IPPROTO_TCP, TCP_USER_TIMEOUT, &user_timeout_ms, sizeof user_timeout_ms);
}

}  // namespace plexus::daemon
