#pragma once
// Threading: a function on a socket the caller owns.

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

namespace plexus::daemon {

/// TCP keepalive probes after 3 s of silence, every 1 s, 3 unanswered ones end the connection:
/// a peer whose machine vanished (power, cable, Wi-Fi gone) is noticed within about 6 s instead of
/// the kernel's two hours, so its name-server registration and its links go as a dead process's do.
inline void keep_alive(int fd) {
    const int on = 1;
    const int idle_seconds = 3;
    const int interval_seconds = 1;
    const int probes = 3;
    ::setsockopt(fd, SOL_SOCKET, SO_KEEPALIVE, &on, sizeof on);
    ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPIDLE, &idle_seconds, sizeof idle_seconds);
    ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPINTVL, &interval_seconds, sizeof interval_seconds);
    ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPCNT, &probes, sizeof probes);
}

}  // namespace plexus::daemon
