#include "frame_socket.hpp"

#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "client_rings.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/endpoint.hpp"
#include "tls_channel.hpp"

namespace plexus::detail {

namespace {
// Descriptors one receive can bring (the kernel sends at most 253 with one message).
constexpr std::size_t max_received_fds = 253;
}  // namespace

namespace {

bool take_descriptors(msghdr& message, std::deque<int>& fds) {
    if (message.msg_controllen == 0)
        return true;
    for (cmsghdr* header = CMSG_FIRSTHDR(&message); header; header = CMSG_NXTHDR(&message, header)) {
        if (header->cmsg_level != SOL_SOCKET || header->cmsg_type != SCM_RIGHTS)
            continue;
        const std::size_t count = (header->cmsg_len - CMSG_LEN(0)) / sizeof(int);
        for (std::size_t i = 0; i < count; ++i) {
            int fd = -1;
            std::memcpy(&fd, CMSG_DATA(header) + i * sizeof(int), sizeof fd);
            fds.push_back(fd);
        }
    }
    return (message.msg_flags & MSG_CTRUNC) == 0;
}

}  // namespace

ssize_t receive_with_descriptors(int fd, std::uint8_t* at, std::size_t room, int flags, std::deque<int>& fds,
                                 bool& cut_off) {
    iovec piece{at, room};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int) * max_received_fds)];
    msghdr message{};
    message.msg_iov = &piece;
    message.msg_iovlen = 1;
    message.msg_control = control;
    message.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(fd, &message, flags | MSG_CMSG_CLOEXEC);
    cut_off = n > 0 && !take_descriptors(message, fds);
    return n;
}

int FrameSocket::connect_unix(const std::string& path) {
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    if (path.size() >= sizeof address.sun_path)
        throw Error(ErrorCode::usage, "socket path too long: " + path);
    std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0)
        throw Error(ErrorCode::refused, std::string("socket: ") + std::strerror(errno));
    if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
        const int error = errno;
        ::close(fd);
        throw Error(ErrorCode::refused,
                    "no plexusd is running at " + path + " (" + std::strerror(error) +
                        "); start one with `plexusd --embedded-names`, or pass --socket / "
                        "set PLEXUS_SOCKET");
    }
    return fd;
}

int FrameSocket::connect_tcp(const std::string& address) {
    auto endpoint = proto::parse_endpoint(address);
    if (!endpoint)
        throw Error(ErrorCode::usage, "bad address '" + address + "': " + endpoint.error().message);
    addrinfo hints{};
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* found = nullptr;
    if (::getaddrinfo(endpoint->host.c_str(), std::to_string(endpoint->port).c_str(), &hints, &found) != 0 ||
        !found) {
        throw Error(ErrorCode::refused, "cannot resolve " + address);
    }
    int fd = -1;
    int error = 0;
    for (addrinfo* a = found; a; a = a->ai_next) {
        fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
        if (fd >= 0 && ::connect(fd, a->ai_addr, a->ai_addrlen) == 0)
            break;
        error = errno;
        if (fd >= 0)
            ::close(fd);
        fd = -1;
    }
    ::freeaddrinfo(found);
    if (fd < 0)
        throw Error(ErrorCode::refused, "cannot reach " + address + ": " + std::strerror(error));
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    return fd;
}

FrameSocket::FrameSocket(int fd, std::unique_ptr<TlsChannel> tls) : fd_(fd), tls_(std::move(tls)) {}

FrameSocket::~FrameSocket() {
    tls_.reset();  // before its socket closes
    if (fd_ >= 0)
        ::close(fd_);
}

SocketReceived FrameSocket::receive(std::uint8_t* at, std::size_t room, std::deque<int>& fds, int flags) {
    if (in_rings_)
        return in_rings_->receive(at, room, fd_, fds, receive_timeout_, (flags & MSG_DONTWAIT) == 0);
    if (tls_)
        return receive_tls(at, room, flags);
    bool cut_off = false;
    const ssize_t n = receive_with_descriptors(fd_, at, room, flags, fds, cut_off);
    SocketReceived result;
    if (cut_off)
        result.failure = "descriptors from the daemon were cut off";
    if (n == 0) {
        result.failure = "the daemon closed the connection";
        return result;
    }
    if (n < 0) {
        // EAGAIN: a receive timeout passed, or MSG_DONTWAIT found nothing.
        if (errno != EINTR && errno != EAGAIN && errno != EWOULDBLOCK)
            result.failure = std::strerror(errno);
        return result;
    }
    result.bytes = static_cast<std::size_t>(n);
    return result;
}

SocketReceived FrameSocket::receive_tls(std::uint8_t* at, std::size_t room, int flags) {
    SocketReceived result;
    for (;;) {
        const ssize_t n = tls_->receive(at, room);
        if (n > 0) {
            result.bytes = static_cast<std::size_t>(n);
            return result;
        }
        if (n == 0) {
            result.failure = "the peer closed the connection";
            return result;
        }
        if (errno != EAGAIN) {
            result.failure = "the encrypted link broke: " + tls_->failure();
            return result;
        }
        // Nothing decrypted yet: wait as a blocking receive would (up to the receive timeout).
        if ((flags & MSG_DONTWAIT) != 0)
            return result;
        int timeout_ms = -1;
        if (receive_timeout_.count() > 0)
            timeout_ms = static_cast<int>((receive_timeout_.count() + 999) / 1000);
        pollfd readable{fd_, POLLIN, 0};
        const int ready = ::poll(&readable, 1, timeout_ms);
        if (ready == 0 || (ready < 0 && errno == EINTR))
            return result;  // as a timed-out receive: nothing
    }
}

SocketSent FrameSocket::send_some(const iovec* pieces, std::size_t count) {
    if (out_rings_)
        return out_rings_->send_some(pieces, count);
    if (tls_) {
        const ssize_t n = tls_->send(pieces, count);
        if (n >= 0)
            return {static_cast<std::size_t>(n), false, std::nullopt};
        if (errno == EAGAIN)
            return {0, true, std::nullopt};
        return {0, false, "the encrypted link broke: " + tls_->failure()};
    }
    msghdr message{};
    message.msg_iov = const_cast<iovec*>(pieces);
    message.msg_iovlen = count;
    for (;;) {
        const ssize_t n = ::sendmsg(fd_, &message, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n >= 0)
            return {static_cast<std::size_t>(n), false, std::nullopt};
        if (errno == EINTR)
            continue;
        if (errno == EAGAIN || errno == EWOULDBLOCK)
            return {0, true, std::nullopt};
        return {0, false, std::string(std::strerror(errno))};
    }
}

bool FrameSocket::wait_writable(int timeout_ms) {
    if (out_rings_)
        return out_rings_->wait_writable(fd_, timeout_ms);
    pollfd room{fd_, POLLOUT, 0};
    return ::poll(&room, 1, timeout_ms) > 0 && (room.revents & POLLOUT);
}

void FrameSocket::set_receive_timeout(std::chrono::microseconds timeout) {
    receive_timeout_ = timeout;
    if (in_rings_)
        return;
    timeval tv{static_cast<time_t>(timeout.count() / 1000000),
               static_cast<suseconds_t>(timeout.count() % 1000000)};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
}

void FrameSocket::set_send_buffer(int bytes) {
    if (out_rings_)
        return;
    ::setsockopt(fd_, SOL_SOCKET, SO_SNDBUF, &bytes, sizeof bytes);
}

bool FrameSocket::await_descriptor(std::deque<int>& fds, int timeout_ms) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (fds.empty() && in_rings_) {
        std::optional<std::string> failure;
        if (!in_rings_->drain_socket(fd_, fds, failure))
            return !fds.empty();
        if (!fds.empty())
            break;
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0)
            return false;
        pollfd readable{fd_, POLLIN, 0};
        ::poll(&readable, 1, static_cast<int>(left.count()));
    }
    return !fds.empty();
}

void FrameSocket::shutdown() {
    ::shutdown(fd_, SHUT_RDWR);
}

}  // namespace plexus::detail
