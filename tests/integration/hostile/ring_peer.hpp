#pragma once
// A raw client of the daemon's shared-memory rings (PROTOCOL.md, "Rings"), for the hostile-peer
// tests of rings_test.cpp. hostile_peer.hpp's Stream reads with recv(), which drops the
// descriptors a `rings` answer carries; this peer reads the socket with recvmsg, maps the region
// itself and drives proto::RingWriter / RingReader over it, so that a test can play by the rules
// and then, at any moment, write whatever it likes into the region: positions, flags, bytes.
// Every wait is bounded by a deadline; nothing sleeps for a fixed time.
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/stat.h>

#include <deque>
#include <memory>

#include "hostile_peer.hpp"
#include "plexus/proto/rings.hpp"

namespace plexus::test::hostile {

class RingPeer : public FrameSource<RingPeer> {
public:
    /// Connects to the daemon's Unix socket; nothing is sent yet.
    explicit RingPeer(const Daemon& daemon) : fd_(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0)) {
        if (fd_ < 0)
            throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
        sockaddr_un address{};
        address.sun_family = AF_UNIX;
        const std::string& path = daemon.socket();
        if (path.size() >= sizeof address.sun_path)
            throw std::runtime_error("socket path too long: " + path);
        std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
        if (::connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0)
            throw std::runtime_error("cannot connect to " + path + ": " + std::strerror(errno));
        ::fcntl(fd_, F_SETFL, ::fcntl(fd_, F_GETFL) | O_NONBLOCK);
    }
    RingPeer(const RingPeer&) = delete;
    RingPeer& operator=(const RingPeer&) = delete;
    ~RingPeer() {
        if (region_)
            ::munmap(region_, layout_.region_size());
        for (const int fd : descriptors_) {
            if (fd >= 0)
                ::close(fd);
        }
        for (const int fd : stray_descriptors_)
            ::close(fd);
        close_socket();
    }

    /// Says hello as a client and asks for rings, with `then` in the same write (bytes a client
    /// must not send on the socket after the request); true once the region is mapped.
    bool start(std::uint64_t ring_bytes = 0, const Bytes& then = {}) {
        Bytes opening = concat(hello_frame("client"), proto::make_rings_request(ring_bytes));
        opening.insert(opening.end(), then.begin(), then.end());
        if (!send_on_socket(opening)) {
            ADD_FAILURE() << "could not send the hello and the rings request";
            return false;
        }
        return take_rings_answer();
    }

    /// Reads the socket's frames until the `rings` answer and maps what it came with; false (and a
    /// test failure unless `quiet`) when it did not come, was refused or is malformed.
    bool take_rings_answer(bool quiet = false) {
        const auto deadline = Clock::now() + exchange_timeout;
        for (;;) {
            const auto decoded = socket_decoder_.decode(socket_bytes_);
            if (decoded.status == proto::DecodeStatus::bad) {
                ADD_FAILURE() << "the daemon sent bytes that are not a frame: " << decoded.error;
                return false;
            }
            if (decoded.status == proto::DecodeStatus::frame) {
                Frame frame{decoded.type, Bytes(decoded.fields.begin(), decoded.fields.end())};
                socket_bytes_.erase(socket_bytes_.begin(),
                                    socket_bytes_.begin() + static_cast<std::ptrdiff_t>(decoded.used));
                socket_frames_.push_back(frame);
                if (frame.type == FrameType::rings)
                    return map_rings(frame, quiet);
                continue;
            }
            if (!read_socket(deadline)) {
                if (!quiet)
                    ADD_FAILURE() << "no rings answer: the socket " << end_name(socket_end_);
                return false;
            }
        }
    }

    /// Frames the daemon sent on the socket (the hello, the rings answer, an error before the switch).
    const std::vector<Frame>& socket_frames() const { return socket_frames_; }

    /// Sends raw bytes on the socket (after the switch, a protocol error).
    bool send_on_socket(ByteView bytes) { return send_all(fd_, bytes, Clock::now() + exchange_timeout); }

    /// Writes `bytes` into the ring to the daemon as a well-behaved client does, waking it every
    /// time (a spurious wake-up costs it nothing but a look); false when the daemon's position is
    /// impossible or no room came before the deadline.
    bool send(ByteView bytes, Clock::time_point deadline) {
        std::size_t sent = 0;
        while (sent < bytes.size()) {
            iovec piece{const_cast<std::uint8_t*>(bytes.data() + sent), bytes.size() - sent};
            bool wake = false;
            const auto n = to_daemon_.write_some(&piece, 1, wake);
            if (!n) {
                ADD_FAILURE() << "the daemon's head in the ring to it is impossible";
                return false;
            }
            sent += *n;
            wake_daemon();
            if (*n > 0)
                continue;
            if (to_daemon_.prepare_to_wait())
                continue;
            const bool woken = wait_readable(descriptor(proto::to_daemon_space), deadline);
            to_daemon_.done_waiting();
            if (!woken)
                return false;
        }
        return true;
    }
    bool send(ByteView bytes) { return send(bytes, Clock::now() + exchange_timeout); }

    /// Signals the to-daemon data eventfd, as a producer does when the daemon sleeps.
    void wake_daemon() { signal(descriptor(proto::to_daemon_data)); }

    /// The next whole frame from the ring to the client; nullopt when the daemon closed the socket
    /// and the ring holds no more, or at the deadline (socket_end() says which: open at the deadline).
    std::optional<Frame> next_frame(Clock::time_point deadline) {
        for (;;) {
            const auto decoded = ring_decoder_.decode(ring_bytes_read_);
            if (decoded.status == proto::DecodeStatus::frame) {
                Frame frame{decoded.type, Bytes(decoded.fields.begin(), decoded.fields.end())};
                ring_bytes_read_.erase(ring_bytes_read_.begin(),
                                       ring_bytes_read_.begin() + static_cast<std::ptrdiff_t>(decoded.used));
                return frame;
            }
            if (decoded.status == proto::DecodeStatus::bad) {
                ADD_FAILURE() << "the daemon wrote bytes into the ring that are not a frame: "
                              << decoded.error;
                ring_bytes_read_.clear();
            }
            if (!read_ring(deadline))
                return std::nullopt;
        }
    }
    std::optional<Frame> next_frame() { return next_frame(Clock::now() + exchange_timeout); }

    /// Waits until the daemon closes the socket, reading nothing from the ring; the end it saw.
    End wait_for_socket_end(Clock::time_point deadline) {
        while (socket_end_ == End::open && read_socket(deadline)) {
        }
        return socket_end_;
    }
    End wait_for_socket_end() { return wait_for_socket_end(Clock::now() + exchange_timeout); }
    End socket_end() const { return socket_end_; }

    void shutdown_socket_write() { ::shutdown(fd_, SHUT_WR); }
    void close_socket() {
        if (fd_ >= 0)
            ::close(fd_);
        fd_ = -1;
    }

    // The region as the client sees it: everything here may be written at will.
    proto::RingControl& to_daemon_control() { return control_at(proto::RingLayout::to_daemon_control); }
    proto::RingControl& to_client_control() { return control_at(proto::RingLayout::to_client_control); }
    std::uint8_t* to_daemon_bytes() { return region_ + layout_.to_daemon_data(); }
    std::uint8_t* region() { return region_; }
    std::size_t ring_bytes() const { return layout_.ring_bytes; }
    std::size_t region_size() const { return layout_.region_size(); }
    /// One of the five descriptors of the answer (the region's memfd stays open for the tests).
    int descriptor(proto::RingDescriptor which) const { return descriptors_.at(which); }
    /// Bytes this peer has published into the ring to the daemon (its own tail).
    std::uint64_t written() const {
        return control_at(proto::RingLayout::to_daemon_control).tail.load(std::memory_order_relaxed);
    }

    static void signal(int fd) {
        const std::uint64_t one = 1;
        [[maybe_unused]] const auto ignored = ::write(fd, &one, sizeof one);
    }
    /// Closes this peer's copy of a descriptor (the region stays mapped).
    void close_descriptor(proto::RingDescriptor which) {
        ::close(descriptors_.at(which));
        descriptors_.at(which) = -1;
    }
    /// Clears O_NONBLOCK on this peer's copy of a descriptor: what the daemon shares with it (the
    /// same open file description) becomes blocking for the daemon too.
    void make_blocking(proto::RingDescriptor which) {
        const int fd = descriptor(which);
        ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
    }

private:
    proto::RingControl& control_at(std::size_t offset) const {
        return *reinterpret_cast<proto::RingControl*>(region_ + offset);
    }

    bool map_rings(const Frame& frame, bool quiet) {
        const auto answer = proto::decode_rings_answer(frame.fields);
        if (!answer) {
            ADD_FAILURE() << "undecodable rings answer: " << answer.error().message;
            return false;
        }
        if (answer->ring_bytes == 0) {
            if (!quiet)
                ADD_FAILURE() << "rings refused: " << answer->reason;
            return false;
        }
        if (received_descriptors_.size() != proto::ring_descriptors) {
            ADD_FAILURE() << "the rings answer came with " << received_descriptors_.size() << " descriptors";
            return false;
        }
        for (std::size_t i = 0; i < descriptors_.size(); ++i) {
            descriptors_[i] = received_descriptors_.front();
            received_descriptors_.pop_front();
        }
        layout_.ring_bytes = static_cast<std::size_t>(answer->ring_bytes);
        void* mapped = ::mmap(nullptr, layout_.region_size(), PROT_READ | PROT_WRITE, MAP_SHARED,
                              descriptor(proto::ring_region), 0);
        if (mapped == MAP_FAILED) {
            ADD_FAILURE() << "cannot map the rings: " << std::strerror(errno);
            return false;
        }
        region_ = static_cast<std::uint8_t*>(mapped);
        to_daemon_ = proto::RingWriter(&to_daemon_control(), to_daemon_bytes(), layout_.ring_bytes);
        from_daemon_ =
            proto::RingReader(&to_client_control(), region_ + layout_.to_client_data(), layout_.ring_bytes);
        return true;
    }

    /// One recvmsg of the socket: its bytes to socket_bytes_, its descriptors kept in order.
    /// False when the socket ended (socket_end_ says how) or the deadline passed (it stays open).
    bool read_socket(Clock::time_point deadline) {
        for (;;) {
            if (fd_ < 0) {
                socket_end_ = End::eof;
                return false;
            }
            std::array<std::uint8_t, 64 * 1024> chunk{};
            iovec piece{chunk.data(), chunk.size()};
            alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int) * 253)];
            msghdr message{};
            message.msg_iov = &piece;
            message.msg_iovlen = 1;
            message.msg_control = control;
            message.msg_controllen = sizeof control;
            const ssize_t n = ::recvmsg(fd_, &message, MSG_DONTWAIT | MSG_CMSG_CLOEXEC);
            if (n >= 0) {
                for (cmsghdr* h = CMSG_FIRSTHDR(&message); h; h = CMSG_NXTHDR(&message, h)) {
                    if (h->cmsg_level != SOL_SOCKET || h->cmsg_type != SCM_RIGHTS)
                        continue;
                    const std::size_t count = (h->cmsg_len - CMSG_LEN(0)) / sizeof(int);
                    for (std::size_t i = 0; i < count; ++i) {
                        int fd = -1;
                        std::memcpy(&fd, CMSG_DATA(h) + i * sizeof(int), sizeof fd);
                        // Before the region is mapped they belong to the rings answer; after, to
                        // shared-memory regions this peer never asked for: closed at the end.
                        if (region_)
                            stray_descriptors_.push_back(fd);
                        else
                            received_descriptors_.push_back(fd);
                    }
                }
            }
            if (n > 0) {
                // After the switch the socket carries only one-byte markers with descriptors.
                if (!region_)
                    socket_bytes_.insert(socket_bytes_.end(), chunk.begin(), chunk.begin() + n);
                return true;
            }
            if (n == 0) {
                socket_end_ = End::eof;
                return false;
            }
            if (errno == EINTR)
                continue;
            if (errno != EAGAIN && errno != EWOULDBLOCK) {
                socket_end_ = End::reset;
                return false;
            }
            pollfd p{fd_, POLLIN, 0};
            if (::poll(&p, 1, milliseconds_until(deadline)) == 0)
                return false;  // the deadline: socket_end_ stays open
        }
    }

    /// Brings what the ring holds into ring_bytes_read_, waiting for the daemon when it is empty.
    /// False when the socket ended with the ring empty, or at the deadline.
    bool read_ring(Clock::time_point deadline) {
        for (;;) {
            std::array<std::uint8_t, 64 * 1024> chunk{};
            bool wake = false;
            const auto n = from_daemon_.read_some(chunk.data(), chunk.size(), wake);
            if (!n) {
                ADD_FAILURE() << "the daemon's tail in the ring to the client is impossible";
                return false;
            }
            if (wake)
                signal(descriptor(proto::to_client_space));
            if (*n > 0) {
                ring_bytes_read_.insert(ring_bytes_read_.end(), chunk.begin(), chunk.begin() + *n);
                return true;
            }
            if (socket_end_ != End::open)
                return false;  // what the daemon wrote before it closed was read first
            if (from_daemon_.prepare_to_wait())
                continue;
            pollfd watched[2] = {{descriptor(proto::to_client_data), POLLIN, 0}, {fd_, POLLIN, 0}};
            const int ready = ::poll(watched, 2, milliseconds_until(deadline));
            from_daemon_.done_waiting();
            if (ready == 0)
                return false;  // the deadline
            if (watched[0].revents & POLLIN) {
                std::uint64_t count = 0;
                [[maybe_unused]] const auto ignored = ::read(watched[0].fd, &count, sizeof count);
            }
            if (watched[1].revents != 0)
                read_socket(deadline);  // a marker, or the end: the ring is looked at once more
        }
    }

    static bool wait_readable(int fd, Clock::time_point deadline) {
        pollfd p{fd, POLLIN, 0};
        if (::poll(&p, 1, milliseconds_until(deadline)) <= 0)
            return false;
        std::uint64_t count = 0;
        [[maybe_unused]] const auto ignored = ::read(fd, &count, sizeof count);
        return true;
    }

    int fd_ = -1;
    End socket_end_ = End::open;
    Bytes socket_bytes_;
    std::vector<Frame> socket_frames_;
    proto::FrameDecoder socket_decoder_{};
    std::deque<int> received_descriptors_;
    std::vector<int> stray_descriptors_;
    std::array<int, proto::ring_descriptors> descriptors_{-1, -1, -1, -1, -1};
    proto::RingLayout layout_;
    std::uint8_t* region_ = nullptr;
    proto::RingWriter to_daemon_;
    proto::RingReader from_daemon_;
    Bytes ring_bytes_read_;
    proto::FrameDecoder ring_decoder_{};
};

}  // namespace plexus::test::hostile
