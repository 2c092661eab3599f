#include "floor_socket.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "floor_frame.hpp"

namespace plexus::bench {

namespace {
// The same numbers as libplexus (client/src/connection.cpp), so that both sides batch alike.
constexpr std::size_t flush_threshold = std::size_t{64} * 1024;
constexpr std::size_t read_chunk = std::size_t{256} * 1024;

std::runtime_error system_error(const std::string& what) {
    return std::runtime_error("floor: " + what + ": " + std::strerror(errno));
}
}  // namespace

FloorSocket::FloorSocket(const std::string& path, std::chrono::milliseconds read_timeout) : path_(path) {
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    if (path.size() >= sizeof address.sun_path)
        throw std::runtime_error("floor: socket path too long: " + path);
    std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0)
        throw system_error("socket");
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
        const auto error = system_error("connect " + path);
        ::close(fd_);
        throw error;
    }
    set_read_timeout(read_timeout);
    in_.resize(read_chunk);
    out_.reserve(2 * flush_threshold);
}

FloorSocket::FloorSocket(int connected_fd, std::string name, std::chrono::milliseconds read_timeout)
    : fd_(connected_fd), path_(std::move(name)) {
    set_read_timeout(read_timeout);
    in_.resize(read_chunk);
    out_.reserve(2 * flush_threshold);
}

void FloorSocket::set_read_timeout(std::chrono::milliseconds read_timeout) {
    // A blocking recv with a timeout: one system call per read, where poll + recv would be two.
    timeval timeout{};
    timeout.tv_sec = static_cast<time_t>(read_timeout.count() / 1000);
    timeout.tv_usec = static_cast<suseconds_t>((read_timeout.count() % 1000) * 1000);
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
}

FloorSocket::~FloorSocket() {
    try {
        flush();
    } catch (...) {
        // The relay may be gone already; nothing to report from a destructor.
    }
    ::close(fd_);
}

void FloorSocket::write(std::uint64_t seq, std::uint64_t time_ns, std::span<const std::uint8_t> payload,
                        bool flush) {
    using namespace floor_frame;
    const std::size_t at = out_.size();
    out_.resize(at + length_size + envelope_size);
    put_u32(out_.data() + at, static_cast<std::uint32_t>(envelope_size + payload.size()));
    put_u64(out_.data() + at + length_size, seq);
    put_u64(out_.data() + at + length_size + 8, time_ns);
    if (payload.size() >= flush_threshold) {
        // A large payload goes straight from the caller's memory, in the same sendmsg as what waits.
        send_all(out_, payload);
        out_.clear();
        return;
    }
    out_.insert(out_.end(), payload.begin(), payload.end());
    if (flush || out_.size() >= flush_threshold)
        this->flush();
}

void FloorSocket::flush() {
    if (out_.empty())
        return;
    send_all(out_, {});
    out_.clear();
}

void FloorSocket::send_all(std::span<const std::uint8_t> first, std::span<const std::uint8_t> second) {
    iovec parts[2] = {{const_cast<std::uint8_t*>(first.data()), first.size()},
                      {const_cast<std::uint8_t*>(second.data()), second.size()}};
    msghdr message{};
    message.msg_iov = parts;
    message.msg_iovlen = second.empty() ? 1 : 2;
    while (message.msg_iovlen > 0) {
        ssize_t n = ::sendmsg(fd_, &message, MSG_NOSIGNAL);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            throw system_error("send to " + path_);
        }
        // Skip what was sent, part by part.
        while (message.msg_iovlen > 0 && static_cast<std::size_t>(n) >= message.msg_iov->iov_len) {
            n -= static_cast<ssize_t>(message.msg_iov->iov_len);
            ++message.msg_iov;
            --message.msg_iovlen;
        }
        if (message.msg_iovlen > 0) {
            message.msg_iov->iov_base = static_cast<std::uint8_t*>(message.msg_iov->iov_base) + n;
            message.msg_iov->iov_len -= static_cast<std::size_t>(n);
        }
    }
}

std::optional<FloorFrame> FloorSocket::read() {
    using namespace floor_frame;
    for (;;) {
        const std::size_t available = in_end_ - in_begin_;
        std::size_t needed = length_size;
        if (available >= length_size) {
            const std::size_t body = get_u32(in_.data() + in_begin_);
            if (body < envelope_size)
                throw std::runtime_error("floor: frame body of " + std::to_string(body) + " bytes");
            needed = length_size + body;
            if (available >= needed) {
                const std::uint8_t* at = in_.data() + in_begin_ + length_size;
                FloorFrame frame{get_u64(at), get_u64(at + 8), {at + envelope_size, body - envelope_size}};
                in_begin_ += needed;
                return frame;
            }
        }
        if (in_begin_ == in_end_)
            in_begin_ = in_end_ = 0;
        if (in_.size() - in_begin_ < needed || in_.size() - in_end_ < read_chunk / 4) {
            // Slide the partial frame to the front; grow only when one frame needs more room.
            std::memmove(in_.data(), in_.data() + in_begin_, available);
            in_begin_ = 0;
            in_end_ = available;
            if (in_.size() < needed)
                in_.resize(needed);
        }
        const ssize_t n = ::recv(fd_, in_.data() + in_end_, in_.size() - in_end_, 0);
        if (n == 0)
            throw std::runtime_error("floor: the relay closed " + path_);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            if (errno == EAGAIN || errno == EWOULDBLOCK)
                return std::nullopt;  // SO_RCVTIMEO passed
            throw system_error("recv from " + path_);
        }
        in_end_ += static_cast<std::size_t>(n);
    }
}

}  // namespace plexus::bench
