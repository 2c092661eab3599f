#pragma once
// What the hostile-peer tests share (tests/integration/hostile/, split by the surface attacked):
// a daemon's listeners, raw frames good and bad, a raw stream socket and the name server's UDP
// port with every wait bounded by a deadline, and the expectations every attack ends with (an
// error frame and a close, memory that does not grow by what a lie declares, everyone else still
// served).
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <functional>
#include <ostream>
#include <random>
#include <stdexcept>
#include <thread>

#include "../harness.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/hello.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/shm.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::test::hostile {

using proto::Bytes;
using proto::ByteView;
using proto::FrameType;
using Clock = std::chrono::steady_clock;

/// How long any one exchange with the daemon may take before the test calls it a hang (a speed
/// bound: stretched by the harness's slowdown() in a sanitized build).
inline const std::chrono::milliseconds exchange_timeout = slower(3s);
/// The daemon's RSS may not grow by more than this over a whole attack (a lie declares GiBs).
/// Stretched by slowdown(): AddressSanitizer's redzones around every block and the freed blocks
/// it holds in quarantine (scripts/sanitize bounds it) grow RSS without any leak; a growth without
/// limit still overshoots it by far.
inline const long max_rss_growth_kib = static_cast<long>(16 * 1024 * slowdown());

// ---------------------------------------------------------------------------------------------
// Listeners

enum class Listener { daemon_tcp, daemon_unix, names_tcp, names_udp };
inline constexpr std::array stream_listeners{Listener::daemon_tcp, Listener::daemon_unix,
                                             Listener::names_tcp};

inline std::string listener_name(Listener listener) {
    switch (listener) {
        case Listener::daemon_tcp:
            return "daemon TCP";
        case Listener::daemon_unix:
            return "daemon Unix socket";
        case Listener::names_tcp:
            return "name server TCP";
        case Listener::names_udp:
            return "name server UDP";
    }
    return "?";
}

/// The role a well-behaved peer of this listener says it has.
inline std::string role_for(Listener listener) {
    return listener == Listener::names_tcp ? "cli" : "client";
}

inline sockaddr_in inet_address(const std::string& host_port) {
    const auto colon = host_port.rfind(':');
    if (colon == std::string::npos)
        throw std::runtime_error("no port in " + host_port);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(std::stoi(host_port.substr(colon + 1))));
    if (::inet_pton(AF_INET, host_port.substr(0, colon).c_str(), &address.sin_addr) != 1) {
        throw std::runtime_error("not an IPv4 address: " + host_port);
    }
    return address;
}

inline int milliseconds_until(Clock::time_point deadline) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    return left <= 0 ? 0 : static_cast<int>(left);
}

/// Sends all of `bytes` on the non-blocking socket `fd`, waiting for room until `deadline`; false
/// if the peer went away first (it may close on the first bad byte) or the deadline passed.
inline bool send_all(int fd, ByteView bytes, Clock::time_point deadline) {
    std::size_t sent = 0;
    while (sent < bytes.size()) {
        const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
        if (n > 0) {
            sent += static_cast<std::size_t>(n);
            continue;
        }
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
            pollfd p{fd, POLLOUT, 0};
            if (::poll(&p, 1, milliseconds_until(deadline)) <= 0)
                return false;
            continue;
        }
        return false;  // EPIPE, ECONNRESET: the peer has closed
    }
    return true;
}

// ---------------------------------------------------------------------------------------------
// Frames

struct Frame {
    FrameType type{};
    Bytes fields;
};

inline Bytes hello_frame(const std::string& role) {
    return proto::encode_hello({proto::protocol_version, role, "hostile"});
}

/// A hello with any magic and version, and raw bytes after the version.
inline Bytes raw_hello(std::string_view magic, std::uint64_t version, const Bytes& tail) {
    Bytes fields(magic.begin(), magic.end());
    proto::append_varint(fields, version);
    fields.insert(fields.end(), tail.begin(), tail.end());
    Bytes out;
    proto::append_frame(out, FrameType::hello, fields);
    return out;
}

/// role and node fields as a version-1 hello lays them out.
inline Bytes role_and_node(const std::string& role) {
    Bytes out;
    proto::append_string(out, role);
    proto::append_string(out, "hostile");
    return out;
}

/// A frame header declaring `length` body bytes, followed by the type byte of a request.
inline Bytes lying_header(std::uint64_t length, FrameType type = FrameType::request) {
    Bytes out;
    proto::append_varint(out, length);
    out.push_back(static_cast<std::uint8_t>(type));
    return out;
}

inline Bytes request_frame(std::uint64_t id, const nlohmann::json& body) {
    return proto::encode_request({id, body});
}

/// A request frame whose body is whatever bytes are given (valid framing, any CBOR).
inline Bytes raw_request(std::uint64_t id, const Bytes& body) {
    Bytes fields;
    proto::append_varint(fields, id);
    fields.insert(fields.end(), body.begin(), body.end());
    Bytes out;
    proto::append_frame(out, FrameType::request, fields);
    return out;
}

inline Bytes cbor(const nlohmann::json& value) {
    return nlohmann::json::to_cbor(value);
}

inline Bytes random_bytes(std::size_t n, std::mt19937& random) {
    Bytes out(n);
    for (auto& byte : out)
        byte = static_cast<std::uint8_t>(random());
    return out;
}

inline Bytes concat(Bytes first, const Bytes& second) {
    first.insert(first.end(), second.begin(), second.end());
    return first;
}

/// The reason of the first error frame among `frames`, if there is one.
inline std::optional<std::string> error_reason(const std::vector<Frame>& frames) {
    for (const auto& frame : frames) {
        if (frame.type != FrameType::error)
            continue;
        auto reason = proto::decode_error(frame.fields);
        if (!reason)
            return "(undecodable error frame: " + reason.error().message + ")";
        return *reason;
    }
    return std::nullopt;
}

// ---------------------------------------------------------------------------------------------
// A raw stream socket (TCP or Unix), non-blocking, every wait bounded by a deadline.

enum class End { open, eof, reset, timeout };

inline std::string end_name(End end) {
    switch (end) {
        case End::open:
            return "still open";
        case End::eof:
            return "closed (EOF)";
        case End::reset:
            return "reset";
        case End::timeout:
            return "no close before the deadline";
    }
    return "?";
}

inline void PrintTo(End end, std::ostream* out) {
    *out << end_name(end);
}

/// What a test reads from a peer that hands over frames one at a time (Derived::next_frame with
/// a deadline): every frame until the end, the reply to a request. A Stream reads them from its
/// socket, a RingPeer (ring_peer.hpp) from its ring.
template <typename Derived>
class FrameSource {
public:
    /// Every frame until the peer closes (or the deadline passes).
    std::vector<Frame> frames_until_closed(Clock::time_point deadline) {
        std::vector<Frame> frames;
        while (auto frame = self().next_frame(deadline))
            frames.push_back(std::move(*frame));
        return frames;
    }
    std::vector<Frame> frames_until_closed() { return frames_until_closed(Clock::now() + exchange_timeout); }

    /// The reply to request `id`, skipping other frames (the peer's hello among them); nullopt if
    /// none came in time.
    std::optional<proto::Reply> reply_to(std::uint64_t id) {
        const auto deadline = Clock::now() + exchange_timeout;
        while (auto frame = self().next_frame(deadline)) {
            if (frame->type == FrameType::error) {
                auto reason = proto::decode_error(frame->fields);
                ADD_FAILURE() << "error frame instead of a reply: "
                              << (reason ? *reason : reason.error().message);
                return std::nullopt;
            }
            if (frame->type != FrameType::reply)
                continue;
            auto reply = proto::decode_reply(frame->fields);
            if (!reply) {
                ADD_FAILURE() << "undecodable reply: " << reply.error().message;
                return std::nullopt;
            }
            if (reply->id == id)
                return *reply;
        }
        return std::nullopt;
    }

private:
    Derived& self() { return static_cast<Derived&>(*this); }
};

class Stream : public FrameSource<Stream> {
public:
    static Stream tcp(const std::string& host_port) {
        const sockaddr_in address = inet_address(host_port);
        Stream stream(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
        if (::connect(stream.fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
            throw std::runtime_error("cannot connect to " + host_port + ": " + std::strerror(errno));
        }
        stream.make_nonblocking();
        return stream;
    }

    static Stream unix_socket(const std::string& path) {
        sockaddr_un address{};
        address.sun_family = AF_UNIX;
        if (path.size() >= sizeof address.sun_path)
            throw std::runtime_error("socket path too long: " + path);
        std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
        Stream stream(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
        if (::connect(stream.fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
            throw std::runtime_error("cannot connect to " + path + ": " + std::strerror(errno));
        }
        stream.make_nonblocking();
        return stream;
    }

    static Stream open(const Daemon& daemon, Listener listener) {
        switch (listener) {
            case Listener::daemon_tcp:
                return tcp(daemon.address());
            case Listener::daemon_unix:
                return unix_socket(daemon.socket());
            case Listener::names_tcp:
                return tcp(daemon.names());
            case Listener::names_udp:
                break;
        }
        throw std::logic_error("not a stream listener");
    }

    Stream(Stream&& other) noexcept
        : fd_(std::exchange(other.fd_, -1)),
          buffer_(std::move(other.buffer_)),
          consumed_(other.consumed_),
          end_(other.end_) {}
    Stream(const Stream&) = delete;
    Stream& operator=(const Stream&) = delete;
    Stream& operator=(Stream&&) = delete;
    ~Stream() { close(); }

    /// Sends all of `bytes`; false if the peer went away first (it may close on the first bad byte).
    bool send(ByteView bytes, Clock::time_point deadline) { return send_all(fd_, bytes, deadline); }
    bool send(ByteView bytes) { return send(bytes, Clock::now() + exchange_timeout); }

    void shutdown_write() { ::shutdown(fd_, SHUT_WR); }
    int descriptor() const { return fd_; }
    void close() {
        if (fd_ >= 0)
            ::close(fd_);
        fd_ = -1;
    }

    /// The next whole frame, or nullopt when the stream ended (see end()) or the deadline passed.
    std::optional<Frame> next_frame(Clock::time_point deadline) {
        for (;;) {
            const auto decoded = decoder_.decode(ByteView(buffer_).subspan(consumed_));
            if (decoded.status == proto::DecodeStatus::frame) {
                Frame frame{decoded.type, Bytes(decoded.fields.begin(), decoded.fields.end())};
                consumed_ += decoded.used;
                return frame;
            }
            if (decoded.status == proto::DecodeStatus::bad) {
                ADD_FAILURE() << "the daemon sent bytes that are not a frame: " << decoded.error;
                buffer_.clear();
                consumed_ = 0;
            }
            if (end_ != End::open || !read_some(deadline))
                return std::nullopt;
        }
    }

    End end() const { return end_; }

private:
    explicit Stream(int fd) : fd_(fd) {
        if (fd_ < 0)
            throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
    }

    void make_nonblocking() { ::fcntl(fd_, F_SETFL, ::fcntl(fd_, F_GETFL) | O_NONBLOCK); }

    /// Reads what is there; false when nothing more will come (end_ says why).
    bool read_some(Clock::time_point deadline) {
        for (;;) {
            std::array<std::uint8_t, 64 * 1024> chunk{};
            const ssize_t n = ::recv(fd_, chunk.data(), chunk.size(), 0);
            if (n > 0) {
                // Frames are taken from the front by moving consumed_, and the taken bytes dropped
                // only here, once per read: erasing each frame's bytes from the front moved the
                // whole buffer each time: 30 s (68 under ASan) for the 262,144 small frames of
                // Hostile_test.AReaderThatNeverReleases... built at -O0 as CI builds tests.
                buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(consumed_));
                consumed_ = 0;
                buffer_.insert(buffer_.end(), chunk.begin(), chunk.begin() + n);
                return true;
            }
            if (n == 0) {
                end_ = End::eof;
                return false;
            }
            if (errno == EINTR)
                continue;
            if (errno == EAGAIN || errno == EWOULDBLOCK) {
                pollfd p{fd_, POLLIN, 0};
                const int ready = ::poll(&p, 1, milliseconds_until(deadline));
                if (ready == 0) {
                    end_ = End::timeout;
                    return false;
                }
                continue;
            }
            end_ = End::reset;
            return false;
        }
    }

    int fd_ = -1;
    Bytes buffer_;
    std::size_t consumed_ = 0;  ///< bytes at the front of buffer_ already handed over as frames
    End end_ = End::open;
    proto::FrameDecoder decoder_{};
};

// ---------------------------------------------------------------------------------------------
// The name server's UDP port.

class Datagrams {
public:
    explicit Datagrams(const std::string& host_port) : fd_(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0)) {
        if (fd_ < 0)
            throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
        const sockaddr_in address = inet_address(host_port);
        if (::connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
            throw std::runtime_error("cannot connect UDP to " + host_port + ": " + std::strerror(errno));
        }
    }
    Datagrams(const Datagrams&) = delete;
    Datagrams& operator=(const Datagrams&) = delete;
    ~Datagrams() { ::close(fd_); }

    bool send(ByteView bytes) {
        return ::send(fd_, bytes.data(), bytes.size(), 0) == static_cast<ssize_t>(bytes.size());
    }

    /// The next datagram, or nullopt if none came before the deadline (or the port is closed).
    std::optional<Bytes> receive(Clock::time_point deadline) {
        for (;;) {
            pollfd p{fd_, POLLIN, 0};
            const int ready = ::poll(&p, 1, milliseconds_until(deadline));
            if (ready == 0)
                return std::nullopt;
            if (ready < 0 && errno == EINTR)
                continue;
            Bytes datagram(65536);
            const ssize_t n = ::recv(fd_, datagram.data(), datagram.size(), MSG_DONTWAIT);
            if (n < 0 && (errno == EINTR || errno == EAGAIN))
                continue;
            if (n < 0)
                return std::nullopt;  // ECONNREFUSED: nobody listens any more
            datagram.resize(static_cast<std::size_t>(n));
            return datagram;
        }
    }

    /// Sends one datagram and decodes the one that answers it as a single frame.
    std::optional<Frame> exchange(ByteView bytes) {
        if (!send(bytes)) {
            ADD_FAILURE() << "cannot send a datagram of " << bytes.size()
                          << " bytes: " << std::strerror(errno);
            return std::nullopt;
        }
        auto datagram = receive(Clock::now() + exchange_timeout);
        if (!datagram)
            return std::nullopt;
        const auto decoded = proto::FrameDecoder().decode(*datagram);
        if (decoded.status != proto::DecodeStatus::frame || decoded.used != datagram->size()) {
            ADD_FAILURE() << "the answer datagram is not exactly one frame";
            return std::nullopt;
        }
        return Frame{decoded.type, Bytes(decoded.fields.begin(), decoded.fields.end())};
    }

private:
    int fd_;
};

// ---------------------------------------------------------------------------------------------
// Expectations shared by the tests

/// On a stream listener: the peer answers `attack` with an error frame (whose reason contains every
/// string of `reason_parts`, if any are given) and closes the connection.
inline void expect_error_then_close(const Daemon& daemon, Listener listener, const Bytes& attack,
                                    const std::vector<std::string>& reason_parts) {
    auto stream = Stream::open(daemon, listener);

    stream.send(attack);
    const auto frames = stream.frames_until_closed();

    EXPECT_EQ(stream.end(), End::eof) << "connection " << end_name(stream.end());
    const auto reason = error_reason(frames);
    ASSERT_TRUE(reason.has_value()) << "no error frame before the close (" << frames.size() << " frames)";
    for (const auto& part : reason_parts) {
        EXPECT_NE(reason->find(part), std::string::npos)
            << "reason '" << *reason << "' lacks '" << part << "'";
    }
}

/// On the UDP listener: `attack` is answered by one error datagram naming every part.
inline void expect_error_datagram(const Daemon& daemon, const Bytes& attack,
                                  const std::vector<std::string>& reason_parts) {
    Datagrams udp(daemon.names());

    auto answer = udp.exchange(attack);

    ASSERT_TRUE(answer.has_value()) << "no answer to a datagram of " << attack.size() << " bytes";
    ASSERT_EQ(answer->type, FrameType::error)
        << "answered with a " << proto::frame_type_name(static_cast<std::uint8_t>(answer->type));
    auto reason = proto::decode_error(answer->fields);
    ASSERT_TRUE(reason.ok()) << reason.error().message;
    for (const auto& part : reason_parts) {
        EXPECT_NE(reason->find(part), std::string::npos)
            << "reason '" << *reason << "' lacks '" << part << "'";
    }
}

/// A well-behaved peer of `listener` still gets an ok answer to a harmless request.
inline bool still_answers(const Daemon& daemon, Listener listener) {
    const nlohmann::json body = listener == Listener::daemon_tcp || listener == Listener::daemon_unix
                                    ? nlohmann::json{{"op", "node"}}
                                    : nlohmann::json{{"op", "ping"}};
    if (listener == Listener::names_udp) {
        Datagrams udp(daemon.names());
        auto answer = udp.exchange(request_frame(7, body));
        if (!answer || answer->type != FrameType::reply)
            return false;
        auto reply = proto::decode_reply(answer->fields);
        return reply && reply->id == 7 && reply->code == proto::ReplyCode::ok;
    }
    auto stream = Stream::open(daemon, listener);
    if (!stream.send(concat(hello_frame(role_for(listener)), request_frame(7, body))))
        return false;
    auto reply = stream.reply_to(7);
    return reply && reply->code == proto::ReplyCode::ok;
}

inline void expect_everyone_still_served(const Daemon& daemon) {
    for (auto listener :
         {Listener::daemon_tcp, Listener::daemon_unix, Listener::names_tcp, Listener::names_udp}) {
        EXPECT_TRUE(still_answers(daemon, listener)) << listener_name(listener) << " stopped answering";
    }
}

/// What every attack ends with: the daemon's memory grew by far less than any lie declared, it
/// still runs, and every listener still serves a well-behaved peer.
inline void expect_unharmed(Daemon& daemon, long rss_before) {
    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

inline const std::array<std::uint64_t, 3> lying_lengths{std::uint64_t{1} << 31, std::uint64_t{1} << 32,
                                                        ~std::uint64_t{0}};

/// Request bodies whose framing is valid but that are not a request.
inline std::vector<std::pair<std::string, Bytes>> malformed_request_bodies() {
    Bytes deep(200, 0x81);  // 200 nested one-element arrays
    deep.push_back(0x00);
    return {
        {"a CBOR array", cbor(nlohmann::json::array({1, 2}))},
        {"a CBOR text", cbor("op")},
        {"a map without op", cbor({{"port", "/x"}})},
        {"a map whose op is a number", cbor({{"op", 5}})},
        {"a map whose op is a map", cbor({{"op", {{"op", "ping"}}}})},
        {"no body at all", {}},
        {"bytes that are not CBOR", {0xff, 0xfe, 0xfd}},
        {"a map followed by more bytes", concat(cbor({{"op", "ping"}}), {0x00})},
        {"a map declaring 2^64-1 entries", {0xbb, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff}},
        {"a map whose op declares a 2^63-byte text",
         {0xa1, 0x62, 'o', 'p', 0x7b, 0x7f, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff}},
        {"a map whose value declares a 4 GiB byte string", {0xa1, 0x61, 'x', 0x5a, 0xff, 0xff, 0xff, 0xff}},
        {"arrays nested 200 deep", deep},
    };
}

/// Says hello as a client on `stream` and opens `port`: its handle, or nullopt (and a test
/// failure) if that did not work.
inline std::optional<std::uint64_t> open_raw_port(Stream& stream, const std::string& port) {
    if (!stream.send(concat(hello_frame("client"), request_frame(1, {{"op", "open"}, {"port", port}})))) {
        ADD_FAILURE() << "could not ask to open " << port;
        return std::nullopt;
    }
    const auto opened = stream.reply_to(1);
    if (!opened || opened->code != proto::ReplyCode::ok) {
        ADD_FAILURE() << "open " << port << " failed: " << (opened ? opened->body.dump() : "no reply");
        return std::nullopt;
    }
    return opened->body["handle"].get<std::uint64_t>();
}

}  // namespace plexus::test::hostile
