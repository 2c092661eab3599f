#include "client_rings.hpp"

#include <poll.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace plexus::detail {

namespace {
std::chrono::nanoseconds spin_from_environment() {
    // Off unless asked for: on a machine of two cores a spinning receiver takes the core the
    // daemon needs to produce what it waits for (docs/BENCHMARKS.md, "Rings").
    const char* text = std::getenv("PLEXUS_SPIN_US");
    if (!text)
        return std::chrono::nanoseconds(0);
    const long us = std::strtol(text, nullptr, 10);
    return std::chrono::microseconds(us > 0 && us <= 1000 ? us : 0);
}

timespec timespec_of(std::chrono::nanoseconds left) {
    return {static_cast<time_t>(left.count() / 1'000'000'000),
            static_cast<long>(left.count() % 1'000'000'000)};
}
}  // namespace

std::shared_ptr<ClientRings> ClientRings::map(std::vector<int> fds, std::uint64_t ring_bytes,
                                              std::string& why) {
    std::shared_ptr<ClientRings> rings(new ClientRings());
    for (std::size_t i = 0; i < fds.size(); ++i) {
        if (i < rings->fds_.size())
            rings->fds_[i] = fds[i];
        else
            ::close(fds[i]);
    }
    if (fds.size() < proto::ring_descriptors) {
        why = "the rings answer came with " + std::to_string(fds.size()) + " descriptors, not " +
              std::to_string(proto::ring_descriptors);
        return nullptr;
    }
    if (ring_bytes != proto::RingLayout::ring_bytes_for(ring_bytes)) {
        why =
            "the daemon's rings are " + std::to_string(ring_bytes) + " bytes: not a size this library takes";
        return nullptr;
    }
    rings->layout_.ring_bytes = static_cast<std::size_t>(ring_bytes);
    const std::size_t size = rings->layout_.region_size();
    void* mapped =
        ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, rings->fds_[proto::ring_region], 0);
    if (mapped == MAP_FAILED) {
        why = std::string("mapping the rings: ") + std::strerror(errno);
        return nullptr;
    }
    rings->region_ = static_cast<std::uint8_t*>(mapped);
    ::close(rings->fds_[proto::ring_region]);  // the mapping is all we need of it
    rings->fds_[proto::ring_region] = -1;
    auto* to_daemon =
        reinterpret_cast<proto::RingControl*>(rings->region_ + proto::RingLayout::to_daemon_control);
    auto* to_client =
        reinterpret_cast<proto::RingControl*>(rings->region_ + proto::RingLayout::to_client_control);
    const auto& layout = rings->layout_;
    rings->to_daemon_ =
        proto::RingWriter(to_daemon, rings->region_ + layout.to_daemon_data(), layout.ring_bytes);
    rings->from_daemon_ =
        proto::RingReader(to_client, rings->region_ + layout.to_client_data(), layout.ring_bytes);
    rings->spin_ = spin_from_environment();
    return rings;
}

ClientRings::~ClientRings() {
    if (region_)
        ::munmap(region_, layout_.region_size());
    for (const int fd : fds_) {
        if (fd >= 0)
            ::close(fd);
    }
}

void ClientRings::signal(int fd) {
    const std::uint64_t one = 1;
    [[maybe_unused]] const auto ignored = ::write(fd, &one, sizeof one);
}

void ClientRings::empty_eventfd(int fd) {
    std::uint64_t count = 0;
    [[maybe_unused]] const auto ignored = ::read(fd, &count, sizeof count);
}

bool ClientRings::drain_socket(int socket_fd, std::deque<int>& fds, std::optional<std::string>& failure) {
    for (;;) {
        std::uint8_t markers[64];
        bool cut_off = false;
        const ssize_t n =
            receive_with_descriptors(socket_fd, markers, sizeof markers, MSG_DONTWAIT, fds, cut_off);
        if (n == 0)
            return false;
        if (n < 0) {
            if (errno == EINTR)
                continue;
            if (errno == EAGAIN || errno == EWOULDBLOCK)
                return true;
            failure = std::strerror(errno);
            return false;
        }
        if (cut_off) {
            failure = "descriptors from the daemon were cut off";
            return false;
        }
    }
}

SocketReceived ClientRings::receive(std::uint8_t* at, std::size_t room, int socket_fd, std::deque<int>& fds,
                                    std::chrono::microseconds timeout, bool wait) {
    using Clock = std::chrono::steady_clock;
    const auto deadline = timeout.count() > 0 ? Clock::now() + timeout : Clock::time_point::max();
    bool spun = false;
    for (;;) {
        bool wake = false;
        const auto n = from_daemon_.read_some(at, room, wake);
        if (!n)
            return {0, std::string("the daemon's ring says it wrote more than the ring holds")};
        if (wake)
            signal(fds_[proto::to_client_space]);
        if (*n > 0)
            return {*n, std::nullopt};
        if (socket_ended_)
            return {0, std::string("the daemon closed the connection")};
        if (!wait) {
            std::optional<std::string> failure;
            if (!drain_socket(socket_fd, fds, failure)) {
                socket_ended_ = true;
                if (failure)
                    return {0, failure};
                continue;  // what the daemon wrote before it closed is read first
            }
            return {};
        }
        if (spin_.count() > 0 && !spun) {
            spun = true;
            const auto until = std::min(deadline, Clock::now() + spin_);
            while (Clock::now() < until) {
                const auto waiting = from_daemon_.available();
                if (!waiting || *waiting > 0)
                    break;
            }
            continue;
        }
        if (from_daemon_.prepare_to_wait())
            continue;
        pollfd watched[2] = {{fds_[proto::to_client_data], POLLIN, 0}, {socket_fd, POLLIN, 0}};
        const auto now = Clock::now();
        int ready = 0;
        if (deadline == Clock::time_point::max()) {
            ready = ::ppoll(watched, 2, nullptr, nullptr);
        } else {
            const timespec left = timespec_of(std::max(deadline - now, Clock::duration::zero()));
            ready = ::ppoll(watched, 2, &left, nullptr);
        }
        from_daemon_.done_waiting();
        if (ready < 0 && errno != EINTR)
            return {0, std::string(std::strerror(errno))};
        if (ready == 0)
            return {};  // the timeout passed
        if (watched[0].revents & POLLIN)
            empty_eventfd(fds_[proto::to_client_data]);
        if (watched[1].revents) {
            std::optional<std::string> failure;
            if (!drain_socket(socket_fd, fds, failure)) {
                socket_ended_ = true;
                if (failure)
                    return {0, failure};
            }
        }
        if (Clock::now() >= deadline) {
            const auto waiting = from_daemon_.available();
            if (waiting && *waiting == 0 && !socket_ended_)
                return {};
        }
    }
}

SocketSent ClientRings::send_some(const iovec* pieces, std::size_t count) {
    bool wake = false;
    const auto n = to_daemon_.write_some(pieces, count, wake);
    if (!n)
        return {0, false, std::string("the daemon's ring says it read more than was written")};
    if (wake)
        signal(fds_[proto::to_daemon_data]);
    if (*n == 0)
        return {0, true, std::nullopt};
    return {*n, false, std::nullopt};
}

bool ClientRings::wait_writable(int socket_fd, int timeout_ms) {
    std::lock_guard one_sleeper(writer_wait_);
    if (to_daemon_.prepare_to_wait())
        return true;
    pollfd watched[2] = {{fds_[proto::to_daemon_space], POLLIN, 0}, {socket_fd, POLLRDHUP, 0}};
    const int ready = ::poll(watched, 2, timeout_ms);
    to_daemon_.done_waiting();
    if (ready > 0 && (watched[0].revents & POLLIN))
        empty_eventfd(fds_[proto::to_daemon_space]);
    const auto room = to_daemon_.room();
    return !room || *room > 0;  // a broken ring shows at the next send
}

}  // namespace plexus::detail
