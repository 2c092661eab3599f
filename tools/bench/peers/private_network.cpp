#include "private_network.hpp"

#include <net/if.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

namespace plexus::bench::peers {

void enter_private_network() {
    if (::unshare(CLONE_NEWNET) != 0) {
        const int error = errno;
        throw std::runtime_error(
            std::string("cannot make a network namespace for DDS (unshare: ") + std::strerror(error) + ")" +
            (error == EPERM ? ": the DDS peers need root, as `plexus-bench hosts` does" : ""));
    }
    // The new namespace's loopback is down; bring it up, and mark it multicast-capable, as a
    // network card is: otherwise Cyclone disables multicast and discovers by unicast to itself.
    const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0)
        throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
    ifreq request{};
    std::strncpy(request.ifr_name, "lo", IFNAMSIZ - 1);
    bool ok = ::ioctl(fd, SIOCGIFFLAGS, &request) == 0;
    if (ok) {
        request.ifr_flags = static_cast<short>(request.ifr_flags | IFF_UP | IFF_MULTICAST);
        ok = ::ioctl(fd, SIOCSIFFLAGS, &request) == 0;
    }
    const int error = errno;
    ::close(fd);
    if (!ok)
        throw std::runtime_error(std::string("cannot bring up loopback in the DDS namespace: ") +
                                 std::strerror(error));
}

}  // namespace plexus::bench::peers
