#include "hosts_floor.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <utility>

#include "floor_frame.hpp"

namespace plexus::bench {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

namespace {

// A lossy stream is over once nothing has arrived for this long (as for Plexus).
constexpr auto idle_timeout = 500ms;
// plexusd's UdpConfig::fragment_bytes, datagrams_per_call and socket buffers (udp_socket.cpp).
constexpr std::size_t fragment_bytes = 1400;
constexpr std::size_t datagrams_per_call = 64;
constexpr int socket_buffer_bytes = 8 * 1024 * 1024;
constexpr std::size_t header_size = 24;
constexpr std::uint16_t group_port = 10200;

std::runtime_error system_error(const std::string& what) {
    return std::runtime_error("floor: " + what + ": " + std::strerror(errno));
}

sockaddr_in ipv4(const std::string& address, std::uint16_t port) {
    sockaddr_in result{};
    result.sin_family = AF_INET;
    result.sin_port = htons(port);
    if (::inet_pton(AF_INET, address.c_str(), &result.sin_addr) != 1)
        throw std::runtime_error("floor: bad address " + address);
    return result;
}

/// An fd closed on destruction.
class Fd {
public:
    Fd() = default;
    explicit Fd(int fd) : fd_(fd) {}
    ~Fd() {
        if (fd_ >= 0)
            ::close(fd_);
    }
    Fd(Fd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
    Fd& operator=(Fd&& other) noexcept {
        std::swap(fd_, other.fd_);
        return *this;
    }
    int get() const { return fd_; }
    int release() { return std::exchange(fd_, -1); }

private:
    int fd_ = -1;
};

void set_receive_timeout(int fd, std::chrono::milliseconds timeout) {
    timeval value{};
    value.tv_sec = static_cast<time_t>(timeout.count() / 1000);
    value.tv_usec = static_cast<suseconds_t>((timeout.count() % 1000) * 1000);
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &value, sizeof value);
}

/// One host's end of a datagram floor: a socket bound to its address that sends (and, unicast,
/// receives), and for multicast a socket bound to a group it joined, which receives.
struct DatagramEnd {
    Fd send;
    Fd multicast_receive;
    sockaddr_in destination{};  ///< where the other end sends to reach this one
    int receive_fd() const { return multicast_receive.get() >= 0 ? multicast_receive.get() : send.get(); }
};

/// Made inside host `k`'s namespace. `group` is the group this end listens on ("" for unicast).
DatagramEnd make_datagram_end(const HostsNetwork& network, int k, const std::string& group) {
    DatagramEnd end;
    network.inside(k, [&] {
        end.send = Fd(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0));
        if (end.send.get() < 0)
            throw system_error("socket");
        const int buffer = socket_buffer_bytes;
        ::setsockopt(end.send.get(), SOL_SOCKET, SO_SNDBUF, &buffer, sizeof buffer);
        ::setsockopt(end.send.get(), SOL_SOCKET, SO_RCVBUF, &buffer, sizeof buffer);
        sockaddr_in local = ipv4(network.address(k), 0);
        if (::bind(end.send.get(), reinterpret_cast<sockaddr*>(&local), sizeof local) != 0)
            throw system_error("bind " + network.address(k));
        socklen_t length = sizeof local;
        ::getsockname(end.send.get(), reinterpret_cast<sockaddr*>(&local), &length);
        end.destination = local;
        // Multicast leaves by eth0, goes one hop, and is not looped back to this host.
        const in_addr interface = ipv4(network.address(k), 0).sin_addr;
        const unsigned char ttl = 1;
        const unsigned char loop = 0;
        ::setsockopt(end.send.get(), IPPROTO_IP, IP_MULTICAST_IF, &interface, sizeof interface);
        ::setsockopt(end.send.get(), IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
        ::setsockopt(end.send.get(), IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop);
        if (group.empty())
            return;
        end.multicast_receive = Fd(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0));
        const int reuse = 1;
        ::setsockopt(end.multicast_receive.get(), SOL_SOCKET, SO_REUSEADDR, &reuse, sizeof reuse);
        ::setsockopt(end.multicast_receive.get(), SOL_SOCKET, SO_RCVBUF, &buffer, sizeof buffer);
        sockaddr_in bound = ipv4(group, group_port);
        if (::bind(end.multicast_receive.get(), reinterpret_cast<sockaddr*>(&bound), sizeof bound) != 0)
            throw system_error("bind " + group);
        ip_mreq join{};
        join.imr_multiaddr = bound.sin_addr;
        join.imr_interface = interface;
        if (::setsockopt(end.multicast_receive.get(), IPPROTO_IP, IP_ADD_MEMBERSHIP, &join, sizeof join) != 0)
            throw system_error("join " + group);
        end.destination = bound;
    });
    return end;
}

/// A fresh group per floor end: measurements that overlap never hear each other.
std::string next_group() {
    static std::atomic<int> next{1};
    return "239.255.90." + std::to_string(next++);
}

using floor_frame::get_u32;
using floor_frame::get_u64;
using floor_frame::put_u32;
using floor_frame::put_u64;

/// The datagrams of one message: headers built here, fragments sent from the payload (gather),
/// up to 64 per sendmmsg.
void send_message(int fd, const sockaddr_in& to, std::uint64_t seq, std::uint64_t time_ns,
                  const std::vector<std::uint8_t>& payload) {
    const std::size_t count =
        std::max<std::size_t>(1, (payload.size() + fragment_bytes - 1) / fragment_bytes);
    std::array<std::array<std::uint8_t, header_size>, datagrams_per_call> headers{};
    std::array<iovec, 2 * datagrams_per_call> pieces{};
    std::array<mmsghdr, datagrams_per_call> messages{};
    std::size_t index = 0;
    while (index < count) {
        const std::size_t batch = std::min(datagrams_per_call, count - index);
        for (std::size_t i = 0; i < batch; ++i) {
            const std::size_t fragment = index + i;
            auto& header = headers[i];
            put_u64(header.data(), seq);
            put_u64(header.data() + 8, time_ns);
            put_u32(header.data() + 16, static_cast<std::uint32_t>(fragment));
            put_u32(header.data() + 20, static_cast<std::uint32_t>(count));
            const std::size_t begin = fragment * fragment_bytes;
            const std::size_t size =
                std::min(payload.size() - std::min(begin, payload.size()), fragment_bytes);
            pieces[2 * i] = {header.data(), header_size};
            pieces[2 * i + 1] = {const_cast<std::uint8_t*>(payload.data() + begin), size};
            messages[i] = {};
            messages[i].msg_hdr.msg_name = const_cast<sockaddr_in*>(&to);
            messages[i].msg_hdr.msg_namelen = sizeof to;
            messages[i].msg_hdr.msg_iov = &pieces[2 * i];
            messages[i].msg_hdr.msg_iovlen = size == 0 ? 1 : 2;
        }
        const int sent = ::sendmmsg(fd, messages.data(), static_cast<unsigned>(batch), 0);
        if (sent < 0) {
            if (errno == EINTR)
                continue;
            throw system_error("sendmmsg");
        }
        index += static_cast<std::size_t>(sent);
    }
}

struct DatagramHeader {
    std::uint64_t seq = 0;
    std::uint64_t time_ns = 0;
    std::uint32_t fragment = 0;
    std::uint32_t fragments = 0;
};

DatagramHeader header_of(const std::uint8_t* datagram) {
    return {get_u64(datagram), get_u64(datagram + 8), get_u32(datagram + 16), get_u32(datagram + 20)};
}

class DatagramLatency : public Measurement {
public:
    DatagramLatency(const HostsNetwork& network, int a, int b, bool multicast, const Options& options)
        : size_(options.size),
          count_(latency_count(options)),
          payload_(options.size, 0x5a),
          near_(make_datagram_end(network, a, multicast ? next_group() : "")),
          far_(make_datagram_end(network, b, multicast ? next_group() : "")),
          buffer_(65536) {
        set_receive_timeout(near_.receive_fd(), stall_timeout);
        set_receive_timeout(far_.receive_fd(), 200ms);
        echo_ = std::jthread([this](const std::stop_token& stop) { echo(stop); });
    }

    ~DatagramLatency() override {
        echo_.request_stop();
        try {
            send_message(near_.send.get(), far_.destination, floor_frame::stop_seq, 0, {});
        } catch (...) {
            // The echo thread also stops on its own within one read timeout.
        }
    }

    RunResult run() override {
        return time_round_trips(count_, size_, {}, [this] { return round_trip(); });
    }

private:
    double round_trip() {
        const auto sent = Clock::now();
        send_message(near_.send.get(), far_.destination, seq_, now_ns(), payload_);
        std::uint32_t arrived = 0;
        for (;;) {
            const ssize_t n = ::recv(near_.receive_fd(), buffer_.data(), buffer_.size(), 0);
            if (n < 0) {
                if (errno == EINTR)
                    continue;
                std::lock_guard lock(echo_error_mutex_);
                throw std::runtime_error("floor: no echo within 10 s (a datagram lost?)" +
                                         (echo_error_.empty() ? "" : ": " + echo_error_));
            }
            if (static_cast<std::size_t>(n) < header_size)
                continue;
            const auto header = header_of(buffer_.data());
            if (header.seq != seq_)
                continue;  // a late echo of an earlier ping
            if (++arrived == header.fragments)
                break;
        }
        const auto back = Clock::now();
        ++seq_;
        return std::chrono::duration<double, std::micro>(back - sent).count() / 2;
    }

    /// Sends every datagram back as it comes.
    void echo(const std::stop_token& stop) {
        std::vector<std::uint8_t> buffer(65536);
        try {
            while (!stop.stop_requested()) {
                const ssize_t n = ::recv(far_.receive_fd(), buffer.data(), buffer.size(), 0);
                if (n < 0)
                    continue;  // timeout: look at the stop token again
                if (static_cast<std::size_t>(n) < header_size)
                    continue;
                if (header_of(buffer.data()).seq == floor_frame::stop_seq)
                    return;
                if (::sendto(far_.send.get(), buffer.data(), static_cast<std::size_t>(n), 0,
                             reinterpret_cast<const sockaddr*>(&near_.destination),
                             sizeof near_.destination) < 0)
                    throw system_error("sendto");
            }
        } catch (const std::exception& e) {
            std::lock_guard lock(echo_error_mutex_);
            echo_error_ = e.what();
        }
    }

    std::size_t size_;
    std::size_t count_;
    std::vector<std::uint8_t> payload_;
    DatagramEnd near_;
    DatagramEnd far_;
    std::vector<std::uint8_t> buffer_;
    std::uint64_t seq_ = 1;
    std::mutex echo_error_mutex_;
    std::string echo_error_;
    std::jthread echo_;  // last: joined before the sockets it uses are closed
};

class DatagramThroughput : public Measurement {
public:
    DatagramThroughput(const HostsNetwork& network, int a, int b, bool multicast, const Options& options)
        : size_(options.size),
          count_(throughput_count(options)),
          payload_(options.size, 0x5a),
          writer_(make_datagram_end(network, a, "")),
          reader_(make_datagram_end(network, b, multicast ? next_group() : "")) {
        set_receive_timeout(reader_.receive_fd(), idle_timeout);
        stream(std::max<std::size_t>(count_ / 10, 10));  // warm-up, as for Plexus
    }

    RunResult run() override {
        const auto start = Clock::now();
        auto [latencies, last] = stream(count_);
        const std::size_t arrived = latencies.size();
        if (arrived == 0)
            throw std::runtime_error("floor: none of " + std::to_string(count_) + " messages arrived");
        auto result = summarize(latencies, arrived, size_, last - start, 0);
        result.lost = static_cast<double>(count_ - arrived) / static_cast<double>(count_);
        return result;
    }

private:
    struct Streamed {
        std::vector<double> latencies_us;
        Clock::time_point last;
    };

    Streamed stream(std::size_t count) {
        const std::uint64_t first = written_ + 1;
        written_ += count;
        Streamed streamed;
        streamed.latencies_us.reserve(count);
        std::string error;
        std::jthread reader([&] {
            try {
                receive(first, first + count, streamed);
            } catch (const std::exception& e) {
                error = e.what();
            }
        });
        for (std::uint64_t seq = first; seq < first + count; ++seq)
            send_message(writer_.send.get(), reader_.destination, seq, now_ns(), payload_);
        reader.join();
        if (!error.empty())
            throw std::runtime_error(error);
        return streamed;
    }

    /// Reassembles messages first..end-1 into one buffer, copying each fragment to its place.
    void receive(std::uint64_t first, std::uint64_t end, Streamed& streamed) {
        std::vector<std::uint8_t> datagram(65536);
        std::vector<std::uint8_t> message(size_);
        std::uint64_t current = 0;  // the message being reassembled; 0: none
        std::uint32_t fragments = 0;
        const auto give_up = Clock::now() + stall_timeout;
        streamed.last = Clock::now();
        bool any = false;
        for (;;) {
            const ssize_t n = ::recv(reader_.receive_fd(), datagram.data(), datagram.size(), 0);
            if (n < 0) {
                if (errno == EINTR || (!any && Clock::now() < give_up))
                    continue;
                return;  // quiet for idle_timeout: the rest was lost
            }
            if (static_cast<std::size_t>(n) < header_size)
                continue;
            const auto header = header_of(datagram.data());
            if (header.seq < first || header.seq < current)
                continue;  // of an earlier stream, or of a message already given up
            any = true;
            if (header.seq != current) {
                current = header.seq;  // a new message; an unfinished one before it is lost
                fragments = 0;
            }
            const std::size_t at = static_cast<std::size_t>(header.fragment) * fragment_bytes;
            const std::size_t body = static_cast<std::size_t>(n) - header_size;
            if (at + body > message.size())
                throw std::runtime_error("floor: a fragment beyond its message");
            std::memcpy(message.data() + at, datagram.data() + header_size, body);
            if (++fragments < header.fragments)
                continue;
            streamed.latencies_us.push_back(static_cast<double>(now_ns() - header.time_ns) / 1e3);
            streamed.last = Clock::now();
            current = header.seq + 1;
            fragments = 0;
            if (header.seq + 1 >= end)
                return;
        }
    }

    std::size_t size_;
    std::size_t count_;
    std::vector<std::uint8_t> payload_;
    DatagramEnd writer_;
    DatagramEnd reader_;
    std::uint64_t written_ = 0;
};

}  // namespace

FloorEnds tcp_floor_ends(const HostsNetwork& network, int a, int b) {
    Fd listener;
    sockaddr_in address = ipv4(network.address(b), 0);
    network.inside(b, [&] {
        listener = Fd(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
        if (listener.get() < 0)
            throw system_error("socket");
        if (::bind(listener.get(), reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
            ::listen(listener.get(), 1) != 0)
            throw system_error("listen on " + network.address(b));
        socklen_t length = sizeof address;
        ::getsockname(listener.get(), reinterpret_cast<sockaddr*>(&address), &length);
    });
    Fd near;
    network.inside(a, [&] {
        near = Fd(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
        if (near.get() < 0 ||
            ::connect(near.get(), reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0)
            throw system_error("connect to " + network.address(b));
    });
    Fd far(::accept4(listener.get(), nullptr, nullptr, SOCK_CLOEXEC));
    if (far.get() < 0)
        throw system_error("accept");
    const int on = 1;  // as plexusd's links
    ::setsockopt(near.get(), IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    ::setsockopt(far.get(), IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    FloorEnds ends;
    ends.near =
        std::make_unique<FloorSocket>(near.release(), "tcp floor, host " + std::to_string(a), stall_timeout);
    ends.far =
        std::make_unique<FloorSocket>(far.release(), "tcp floor, host " + std::to_string(b), stall_timeout);
    return ends;
}

std::unique_ptr<Measurement> datagram_floor_latency(const HostsNetwork& network, int a, int b, bool multicast,
                                                    const Options& options) {
    return std::make_unique<DatagramLatency>(network, a, b, multicast, options);
}

std::unique_ptr<Measurement> datagram_floor_throughput(const HostsNetwork& network, int a, int b,
                                                       bool multicast, const Options& options) {
    return std::make_unique<DatagramThroughput>(network, a, b, multicast, options);
}

}  // namespace plexus::bench
