#include "relay.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

#include "floor_frame.hpp"

namespace plexus::bench {

namespace {

constexpr std::size_t initial_buffer = std::size_t{256} * 1024;

[[noreturn]] void die(const std::string& what) {
    throw std::runtime_error("relay: " + what + ": " + std::strerror(errno));
}

int listen_unix(const std::string& path) {
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    if (path.size() >= sizeof address.sun_path)
        throw std::runtime_error("relay: socket path too long");
    std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0)
        die("socket");
    ::unlink(path.c_str());
    if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0)
        die("bind " + path);
    if (::listen(fd, 8) != 0)
        die("listen");
    return fd;
}

sockaddr_in ipv4(const std::string& host, int port) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    if (::inet_pton(AF_INET, host.c_str(), &address.sin_addr) != 1)
        throw std::runtime_error("relay: bad address " + host);
    return address;
}

/// A socket of `type` bound to `host`:0; the port it got in `port`.
int bound(int type, const std::string& host, int& port) {
    const int fd = ::socket(AF_INET, type | SOCK_CLOEXEC, 0);
    if (fd < 0)
        die("socket");
    sockaddr_in address = ipv4(host, 0);
    if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0)
        die("bind " + host);
    socklen_t length = sizeof address;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
    port = ntohs(address.sin_port);
    return fd;
}

/// A socket of `type` connected to `address_text` (HOST:PORT).
int connected(int type, const std::string& address_text) {
    const auto colon = address_text.rfind(':');
    const sockaddr_in address =
        ipv4(address_text.substr(0, colon), std::stoi(address_text.substr(colon + 1)));
    const int fd = ::socket(AF_INET, type | SOCK_CLOEXEC, 0);
    if (fd < 0)
        die("socket");
    if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0)
        die("connect " + address_text);
    return fd;
}

int listen_tcp(const std::string& host, int& port) {
    const int fd = bound(SOCK_STREAM, host, port);
    if (::listen(fd, 8) != 0)
        die("listen tcp");
    return fd;
}

void no_delay(int fd) {
    // As plexusd does on its links: small frames go out at once.
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
}

int connect_tcp(const std::string& address_text) {
    const int fd = connected(SOCK_STREAM, address_text);
    no_delay(fd);
    return fd;
}

/// The far side's UDP socket, connected to the near side's, which learns its address from a
/// one-byte hello (frames are at least a length prefix long, so it is never taken for one).
int connect_udp(const std::string& address_text) {
    const int fd = connected(SOCK_DGRAM, address_text);
    const std::uint8_t hello = 0;
    if (::send(fd, &hello, 1, 0) != 1)
        die("send hello");
    return fd;
}

/// Near side: waits for the far side's hello and connects the socket back to it.
void take_udp_hello(int fd) {
    sockaddr_in from{};
    socklen_t length = sizeof from;
    std::uint8_t byte = 0;
    if (::recvfrom(fd, &byte, 1, 0, reinterpret_cast<sockaddr*>(&from), &length) < 0)
        die("recv hello");
    if (::connect(fd, reinterpret_cast<sockaddr*>(&from), length) != 0)
        die("connect udp back");
}

void write_ready(const std::string& path, const std::string& link_host, int link_port) {
    const std::string temporary = path + ".tmp";
    {
        std::ofstream out(temporary);
        out << R"({"pid":)" << ::getpid();
        if (link_port > 0)
            out << ",\"link\":\"" << link_host << ':' << link_port << '"';
        out << "}\n";
    }
    std::filesystem::rename(temporary, path);  // readers never see half a file
}

/// Frames travelling from one side to the other.
struct Direction {
    int from = -1;
    int to = -1;
    std::vector<std::uint8_t> buffer = std::vector<std::uint8_t>(initial_buffer);
    std::size_t sent = 0;    // [0, sent) is done with
    std::size_t framed = 0;  // [sent, framed) is whole frames waiting to be sent
    std::size_t end = 0;     // [framed, end) is the start of a frame still arriving
    bool blocked = false;    // `to` could not take everything: wait for EPOLLOUT, stop reading `from`
};

void scan_frames(Direction& d) {
    using namespace floor_frame;
    while (d.end - d.framed >= length_size) {
        const std::size_t whole = length_size + get_u32(d.buffer.data() + d.framed);
        if (d.framed + whole > d.end) {
            // Make sure the frame will fit once the sent part is reclaimed.
            if (whole > d.buffer.size())
                d.buffer.resize(whole);
            return;
        }
        d.framed += whole;
    }
}

enum class Pump { ok, closed };

/// Sends whole frames that wait; if nothing waits, reads once. One wake-up, few system calls.
Pump pump(Direction& d) {
    if (d.framed > d.sent) {
        const ssize_t n =
            ::send(d.to, d.buffer.data() + d.sent, d.framed - d.sent, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK) {
                d.blocked = true;
                return Pump::ok;
            }
            if (errno == EINTR)
                return Pump::ok;
            return Pump::closed;
        }
        d.sent += static_cast<std::size_t>(n);
        d.blocked = d.sent < d.framed;
        if (d.blocked)
            return Pump::ok;
    }
    d.blocked = false;
    if (d.sent == d.end) {
        d.sent = d.framed = d.end = 0;
    } else if (d.sent > 0 && d.sent == d.framed && d.buffer.size() - d.end < d.buffer.size() / 4) {
        // Only a partial frame is left: slide it to the front to make room.
        std::memmove(d.buffer.data(), d.buffer.data() + d.sent, d.end - d.sent);
        d.end -= d.sent;
        d.framed = d.sent = 0;
    }
    if (d.end == d.buffer.size())
        return Pump::ok;  // full of whole frames: the next wake-up sends
    const ssize_t n = ::recv(d.from, d.buffer.data() + d.end, d.buffer.size() - d.end, MSG_DONTWAIT);
    if (n == 0)
        return Pump::closed;
    if (n < 0)
        return (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) ? Pump::ok : Pump::closed;
    d.end += static_cast<std::size_t>(n);
    scan_frames(d);
    if (d.framed > d.sent) {
        // Forward at once rather than after another epoll_wait: this is the relay's whole job.
        const ssize_t m =
            ::send(d.to, d.buffer.data() + d.sent, d.framed - d.sent, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (m < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
            return Pump::closed;
        if (m > 0)
            d.sent += static_cast<std::size_t>(m);
        d.blocked = d.sent < d.framed;
    }
    return Pump::ok;
}

/// Reads `fd` unless what leaves through it is held up; waits for room in it while what arrives is.
void update_interest(int epoll, int fd, const Direction& leaving, const Direction& arriving) {
    epoll_event event{};
    event.events = (leaving.blocked ? 0U : static_cast<std::uint32_t>(EPOLLIN)) |
                   (arriving.blocked ? static_cast<std::uint32_t>(EPOLLOUT) : 0U);
    event.data.fd = fd;
    ::epoll_ctl(epoll, EPOLL_CTL_MOD, fd, &event);
}

/// An epoll set waiting for either socket to be readable.
int epoll_reading(int first, int second) {
    const int epoll = ::epoll_create1(EPOLL_CLOEXEC);
    if (epoll < 0)
        die("epoll_create1");
    for (const int fd : {first, second}) {
        epoll_event event{};
        event.events = EPOLLIN;
        event.data.fd = fd;
        if (::epoll_ctl(epoll, EPOLL_CTL_ADD, fd, &event) != 0)
            die("epoll_ctl");
    }
    return epoll;
}

/// Forwards between two connected sockets until either closes.
void forward(int first, int second) {
    Direction forth{first, second};
    Direction back{second, first};
    const int epoll = epoll_reading(first, second);
    epoll_event events[4];
    for (;;) {
        const int ready = ::epoll_wait(epoll, events, 4, -1);
        if (ready < 0) {
            if (errno == EINTR)
                continue;
            die("epoll_wait");
        }
        for (int i = 0; i < ready; ++i) {
            const int fd = events[i].data.fd;
            Direction& out_of_fd = fd == first ? forth : back;
            Direction& into_fd = fd == first ? back : forth;
            const bool was_blocked[2] = {out_of_fd.blocked, into_fd.blocked};
            if ((events[i].events & EPOLLOUT) != 0 && pump(into_fd) == Pump::closed)
                return;
            if ((events[i].events & (EPOLLIN | EPOLLHUP | EPOLLERR)) != 0 && pump(out_of_fd) == Pump::closed)
                return;
            if (was_blocked[0] != out_of_fd.blocked || was_blocked[1] != into_fd.blocked) {
                update_interest(epoll, fd, /*leaving=*/out_of_fd, /*arriving=*/into_fd);
                const int other = fd == first ? second : first;
                update_interest(epoll, other, /*leaving=*/into_fd, /*arriving=*/out_of_fd);
            }
        }
    }
}

void send_all(int fd, const std::uint8_t* data, std::size_t size) {
    while (size > 0) {
        const ssize_t n = ::send(fd, data, size, MSG_NOSIGNAL);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            die("send");
        }
        data += n;
        size -= static_cast<std::size_t>(n);
    }
}

/// Forwards between a client's stream socket and the UDP link until the client closes: every
/// whole frame from the client leaves as one datagram; every datagram goes to the client as it
/// came (it is a whole frame, prefix included). A datagram the socket cannot take is dropped.
void forward_datagrams(int stream, int link) {
    const int epoll = epoll_reading(stream, link);
    std::vector<std::uint8_t> from_stream(initial_buffer);
    std::size_t begin = 0;
    std::size_t end = 0;
    std::vector<std::uint8_t> datagram(65536);
    epoll_event events[2];
    for (;;) {
        const int ready = ::epoll_wait(epoll, events, 2, -1);
        if (ready < 0) {
            if (errno == EINTR)
                continue;
            die("epoll_wait");
        }
        for (int i = 0; i < ready; ++i) {
            if (events[i].data.fd == stream) {
                const ssize_t n =
                    ::recv(stream, from_stream.data() + end, from_stream.size() - end, MSG_DONTWAIT);
                if (n == 0)
                    return;
                if (n < 0)
                    continue;
                end += static_cast<std::size_t>(n);
                while (end - begin >= floor_frame::length_size) {
                    const std::size_t whole =
                        floor_frame::length_size + floor_frame::get_u32(from_stream.data() + begin);
                    if (whole > datagram.size())
                        throw std::runtime_error("relay: a frame larger than a datagram on a udp link");
                    if (begin + whole > end)
                        break;
                    ::send(link, from_stream.data() + begin, whole, MSG_DONTWAIT);
                    begin += whole;
                }
                std::memmove(from_stream.data(), from_stream.data() + begin, end - begin);
                end -= begin;
                begin = 0;
            } else {
                for (;;) {
                    const ssize_t n = ::recv(link, datagram.data(), datagram.size(), MSG_DONTWAIT);
                    if (n < 0)
                        break;
                    if (static_cast<std::size_t>(n) >= floor_frame::length_size)  // not a hello
                        send_all(stream, datagram.data(), static_cast<std::size_t>(n));
                }
            }
        }
    }
}

int run_udp_relay(const RelayOptions& options) {
    const int clients = listen_unix(options.socket);
    int link_port = 0;
    const int link = options.link_listen ? bound(SOCK_DGRAM, options.link_address, link_port)
                                         : connect_udp(options.link_connect);
    write_ready(options.ready_file, options.link_address, link_port);
    if (options.link_listen)
        take_udp_hello(link);
    const int client = ::accept4(clients, nullptr, nullptr, SOCK_CLOEXEC);
    if (client < 0)
        die("accept");
    forward_datagrams(client, link);
    return 0;
}

}  // namespace

int run_relay(const RelayOptions& options) {
    if (options.udp_link) {
        if (!options.link_listen && options.link_connect.empty()) {
            std::fprintf(stderr, "relay: --udp-link needs --link-listen or --link-connect\n");
            return 1;
        }
        try {
            return run_udp_relay(options);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "%s\n", e.what());
            return 1;
        }
    }
    try {
        const int clients = listen_unix(options.socket);
        int link_port = 0;
        const int link_listener = options.link_listen ? listen_tcp(options.link_address, link_port) : -1;
        write_ready(options.ready_file, options.link_address, link_port);
        // Gather the two sides: a client and the link, or (one hop) two clients.
        std::vector<int> sides;
        if (!options.link_connect.empty())
            sides.push_back(connect_tcp(options.link_connect));
        const int wanted_clients = options.link_listen || !options.link_connect.empty() ? 1 : 2;
        int accepted_clients = 0;
        bool link_accepted = link_listener < 0;
        while (sides.size() < 2) {
            pollfd waiting[2] = {{clients, accepted_clients < wanted_clients ? short(POLLIN) : short(0), 0},
                                 {link_listener, link_accepted ? short(0) : short(POLLIN), 0}};
            if (::poll(waiting, link_listener < 0 ? 1 : 2, -1) < 0) {
                if (errno == EINTR)
                    continue;
                die("poll");
            }
            if ((waiting[0].revents & POLLIN) != 0) {
                const int fd = ::accept4(clients, nullptr, nullptr, SOCK_CLOEXEC);
                if (fd < 0)
                    die("accept");
                sides.push_back(fd);
                ++accepted_clients;
            }
            if (link_listener >= 0 && (waiting[1].revents & POLLIN) != 0) {
                const int fd = ::accept4(link_listener, nullptr, nullptr, SOCK_CLOEXEC);
                if (fd < 0)
                    die("accept link");
                no_delay(fd);
                sides.push_back(fd);
                link_accepted = true;
            }
        }
        forward(sides[0], sides[1]);
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 1;
    }
}

}  // namespace plexus::bench
