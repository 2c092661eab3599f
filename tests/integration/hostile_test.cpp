// Bad input and faults (issue 2): random bytes, truncated frames, lying lengths, wrong hellos and
// malformed requests, sent to every listener of a daemon with an embedded name server (daemon TCP,
// daemon Unix socket, name server TCP, name server UDP). Each gets an error frame where the
// protocol allows, the connection is closed, memory does not grow by what a lie declares, and the
// process keeps serving everyone else.
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

#include "harness.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/hello.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/shm.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::test {
namespace {

using proto::Bytes;
using proto::ByteView;
using proto::FrameType;
using Clock = std::chrono::steady_clock;

/// How long any one exchange with the daemon may take before the test calls it a hang (a speed
/// bound: stretched by the harness's slowdown() in a sanitized build).
const std::chrono::milliseconds exchange_timeout = slower(3s);
/// The daemon's RSS may not grow by more than this over a whole attack (a lie declares GiBs).
/// Stretched by slowdown(): AddressSanitizer's redzones around every block and the freed blocks
/// it holds in quarantine (scripts/sanitize bounds it) grow RSS without any leak; a growth without
/// limit still overshoots it by far.
const long max_rss_growth_kib = static_cast<long>(16 * 1024 * slowdown());

// ---------------------------------------------------------------------------------------------
// Listeners

enum class Listener { daemon_tcp, daemon_unix, names_tcp, names_udp };
constexpr std::array stream_listeners{Listener::daemon_tcp, Listener::daemon_unix, Listener::names_tcp};

std::string listener_name(Listener listener) {
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
std::string role_for(Listener listener) {
    return listener == Listener::names_tcp ? "cli" : "client";
}

sockaddr_in inet_address(const std::string& host_port) {
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

int milliseconds_until(Clock::time_point deadline) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    return left <= 0 ? 0 : static_cast<int>(left);
}

// ---------------------------------------------------------------------------------------------
// Frames

struct Frame {
    FrameType type{};
    Bytes fields;
};

Bytes hello_frame(const std::string& role) {
    return proto::encode_hello({proto::protocol_version, role, "hostile"});
}

/// A hello with any magic and version, and raw bytes after the version.
Bytes raw_hello(std::string_view magic, std::uint64_t version, const Bytes& tail) {
    Bytes fields(magic.begin(), magic.end());
    proto::append_varint(fields, version);
    fields.insert(fields.end(), tail.begin(), tail.end());
    Bytes out;
    proto::append_frame(out, FrameType::hello, fields);
    return out;
}

/// role and node fields as a version-1 hello lays them out.
Bytes role_and_node(const std::string& role) {
    Bytes out;
    proto::append_string(out, role);
    proto::append_string(out, "hostile");
    return out;
}

/// A frame header declaring `length` body bytes, followed by the type byte of a request.
Bytes lying_header(std::uint64_t length, FrameType type = FrameType::request) {
    Bytes out;
    proto::append_varint(out, length);
    out.push_back(static_cast<std::uint8_t>(type));
    return out;
}

Bytes request_frame(std::uint64_t id, const nlohmann::json& body) {
    return proto::encode_request({id, body});
}

/// A request frame whose body is whatever bytes are given (valid framing, any CBOR).
Bytes raw_request(std::uint64_t id, const Bytes& body) {
    Bytes fields;
    proto::append_varint(fields, id);
    fields.insert(fields.end(), body.begin(), body.end());
    Bytes out;
    proto::append_frame(out, FrameType::request, fields);
    return out;
}

Bytes cbor(const nlohmann::json& value) {
    return nlohmann::json::to_cbor(value);
}

Bytes random_bytes(std::size_t n, std::mt19937& random) {
    Bytes out(n);
    for (auto& byte : out)
        byte = static_cast<std::uint8_t>(random());
    return out;
}

Bytes concat(Bytes first, const Bytes& second) {
    first.insert(first.end(), second.begin(), second.end());
    return first;
}

/// The reason of the first error frame among `frames`, if there is one.
std::optional<std::string> error_reason(const std::vector<Frame>& frames) {
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

std::string end_name(End end) {
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

void PrintTo(End end, std::ostream* out) {
    *out << end_name(end);
}

class Stream {
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
        : fd_(std::exchange(other.fd_, -1)), buffer_(std::move(other.buffer_)), end_(other.end_) {}
    Stream(const Stream&) = delete;
    Stream& operator=(const Stream&) = delete;
    Stream& operator=(Stream&&) = delete;
    ~Stream() { close(); }

    /// Sends all of `bytes`; false if the peer went away first (it may close on the first bad byte).
    bool send(ByteView bytes, Clock::time_point deadline) {
        std::size_t sent = 0;
        while (sent < bytes.size()) {
            const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
            if (n > 0) {
                sent += static_cast<std::size_t>(n);
                continue;
            }
            if (n < 0 && errno == EINTR)
                continue;
            if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
                pollfd p{fd_, POLLOUT, 0};
                if (::poll(&p, 1, milliseconds_until(deadline)) <= 0)
                    return false;
                continue;
            }
            return false;  // EPIPE, ECONNRESET: the peer has closed
        }
        return true;
    }
    bool send(ByteView bytes) { return send(bytes, Clock::now() + exchange_timeout); }

    void shutdown_write() { ::shutdown(fd_, SHUT_WR); }
    void close() {
        if (fd_ >= 0)
            ::close(fd_);
        fd_ = -1;
    }

    /// The next whole frame, or nullopt when the stream ended (see end()) or the deadline passed.
    std::optional<Frame> next_frame(Clock::time_point deadline) {
        for (;;) {
            const auto decoded = decoder_.decode(buffer_);
            if (decoded.status == proto::DecodeStatus::frame) {
                Frame frame{decoded.type, Bytes(decoded.fields.begin(), decoded.fields.end())};
                buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(decoded.used));
                return frame;
            }
            if (decoded.status == proto::DecodeStatus::bad) {
                ADD_FAILURE() << "the daemon sent bytes that are not a frame: " << decoded.error;
                buffer_.clear();
            }
            if (end_ != End::open || !read_some(deadline))
                return std::nullopt;
        }
    }

    /// Every frame until the peer closes (or the deadline passes); end() says which.
    std::vector<Frame> frames_until_closed(Clock::time_point deadline) {
        std::vector<Frame> frames;
        while (auto frame = next_frame(deadline))
            frames.push_back(std::move(*frame));
        return frames;
    }
    std::vector<Frame> frames_until_closed() { return frames_until_closed(Clock::now() + exchange_timeout); }

    /// The reply to request `id`, skipping the peer's hello; nullopt if none came in time.
    std::optional<proto::Reply> reply_to(std::uint64_t id) {
        const auto deadline = Clock::now() + exchange_timeout;
        while (auto frame = next_frame(deadline)) {
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
void expect_error_then_close(const Daemon& daemon, Listener listener, const Bytes& attack,
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
void expect_error_datagram(const Daemon& daemon, const Bytes& attack,
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
bool still_answers(const Daemon& daemon, Listener listener) {
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

void expect_everyone_still_served(const Daemon& daemon) {
    for (auto listener :
         {Listener::daemon_tcp, Listener::daemon_unix, Listener::names_tcp, Listener::names_udp}) {
        EXPECT_TRUE(still_answers(daemon, listener)) << listener_name(listener) << " stopped answering";
    }
}

const std::array<std::uint64_t, 3> lying_lengths{std::uint64_t{1} << 31, std::uint64_t{1} << 32,
                                                 ~std::uint64_t{0}};

// ---------------------------------------------------------------------------------------------
// Lengths that lie

TEST(Hostile_test, LengthsOverTheLimitAreRefusedAtOnceOnEveryStreamListener) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);

    for (auto listener : stream_listeners) {
        for (auto length : lying_lengths) {
            for (bool after_hello : {false, true}) {
                SCOPED_TRACE(listener_name(listener) + ", declared length " + std::to_string(length) +
                             (after_hello ? ", after a hello" : ", as the first bytes"));
                // Only the header is sent and the connection is kept open: the length alone must be
                // refused, before any body arrives.
                const Bytes attack = after_hello
                                         ? concat(hello_frame(role_for(listener)), lying_header(length))
                                         : lying_header(length);
                expect_error_then_close(daemon, listener, attack, {"exceeds limit", std::to_string(length)});
            }
        }
    }

    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, ARequestOverOneMebibyteIsRefusedAtItsHeaderWhileDataMayBeLarger) {
    // A request body decodes to up to 16 times its size: 1 MiB is the limit, judged from the header.
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);
    for (auto listener : {Listener::daemon_tcp, Listener::daemon_unix}) {
        SCOPED_TRACE(listener_name(listener));
        const std::uint64_t length = proto::max_request_frame + 1;
        expect_error_then_close(daemon, listener, concat(hello_frame("client"), lying_header(length)),
                                {"request frame length", "exceeds limit 1048576"});
    }
    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, APeerThatSendsRequestsButNeverReadsTheRepliesIsHeldBack) {
    // Without a bound the daemon would read every request and keep every reply for a peer that
    // never reads: memory without limit. It stops reading such a peer once replies pile up.
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);
    auto stream = Stream::open(daemon, Listener::daemon_unix);
    ASSERT_TRUE(stream.send(hello_frame("client")));
    Bytes block;
    for (std::uint64_t id = 1; id <= 1000; ++id) {
        const Bytes request = request_frame(id, {{"op", "stats"}});
        block.insert(block.end(), request.begin(), request.end());
    }
    int blocks_sent = 0;
    while (blocks_sent < 500 && stream.send(block, Clock::now() + std::chrono::seconds(2)))
        ++blocks_sent;
    EXPECT_LT(blocks_sent, 500) << "the daemon kept reading 500,000 requests whose replies nobody read";
    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, LengthsOverTheLimitGetAnErrorDatagramFromTheNameServerUdpPort) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);

    for (auto length : lying_lengths) {
        SCOPED_TRACE("declared length " + std::to_string(length));
        expect_error_datagram(daemon, lying_header(length), {"exceeds limit", std::to_string(length)});
        // "After a hello": the name server's UDP port takes requests only, so a hello datagram is
        // refused by itself, and the lie that follows it on the same socket still is.
        Datagrams udp(daemon.names());
        auto hello_answer = udp.exchange(hello_frame("cli"));
        ASSERT_TRUE(hello_answer.has_value());
        EXPECT_EQ(hello_answer->type, FrameType::error);
        auto answer = udp.exchange(lying_header(length));
        ASSERT_TRUE(answer.has_value());
        ASSERT_EQ(answer->type, FrameType::error);
        auto reason = proto::decode_error(answer->fields);
        ASSERT_TRUE(reason.ok());
        EXPECT_NE(reason->find("exceeds limit"), std::string::npos) << *reason;
        // And both in one datagram: still one error datagram.
        expect_error_datagram(daemon, concat(hello_frame("cli"), lying_header(length)), {});
    }

    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, LengthsJustUnderTheLimitDoNotCostTheirSizeInMemoryWhileNoBodyArrives) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);
    std::vector<Stream> open_streams;

    // Four sessions each promise a 64 MiB data frame (allowed) and send only its first bytes.
    for (auto listener :
         {Listener::daemon_tcp, Listener::daemon_unix, Listener::daemon_tcp, Listener::daemon_unix}) {
        auto stream = Stream::open(daemon, listener);
        ASSERT_TRUE(
            stream.send(concat(hello_frame("client"),
                               concat(lying_header(proto::default_max_frame, FrameType::data), {0, 1, 2}))));
        open_streams.push_back(std::move(stream));
    }
    ASSERT_TRUE(still_answers(daemon, Listener::daemon_unix));  // the daemon has read what they sent

    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    open_streams.clear();
    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

// ---------------------------------------------------------------------------------------------
// Random bytes and truncated frames

TEST(Hostile_test, RandomBytesCloseTheConnectionOnEveryStreamListener) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    std::mt19937 random(20240602);
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);

    for (auto listener : stream_listeners) {
        for (std::size_t size : {std::size_t{1}, std::size_t{100}, std::size_t{64 * 1024}}) {
            for (bool after_hello : {false, true}) {
                SCOPED_TRACE(listener_name(listener) + ", " + std::to_string(size) + " random bytes" +
                             (after_hello ? " after a hello" : ""));
                auto stream = Stream::open(daemon, listener);
                const Bytes noise = random_bytes(size, random);

                if (after_hello)
                    stream.send(hello_frame(role_for(listener)));
                stream.send(noise);
                stream.shutdown_write();  // a frame the noise began can now never be finished
                const auto frames = stream.frames_until_closed();

                EXPECT_TRUE(stream.end() == End::eof || stream.end() == End::reset)
                    << "connection " << end_name(stream.end());
                if (auto reason = error_reason(frames)) {
                    EXPECT_FALSE(reason->empty());
                }
            }
        }
    }

    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, RandomDatagramsGetAnErrorDatagram) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    std::mt19937 random(20240602);

    for (std::size_t size : {std::size_t{1}, std::size_t{100}, std::size_t{65507}}) {
        SCOPED_TRACE(std::to_string(size) + " random bytes");
        expect_error_datagram(daemon, random_bytes(size, random), {});
    }
    // An empty datagram too.
    expect_error_datagram(daemon, {}, {});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, ATruncatedFrameFollowedByACloseHarmsNobody) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const Bytes whole = request_frame(1, {{"op", "ping"}, {"port", "/some/port/name/long/enough"}});
    const Bytes half(whole.begin(), whole.begin() + static_cast<std::ptrdiff_t>(whole.size() / 2));

    for (auto listener : stream_listeners) {
        SCOPED_TRACE(listener_name(listener));
        {
            auto stream = Stream::open(daemon, listener);
            ASSERT_TRUE(stream.send(concat(hello_frame(role_for(listener)), half)));
            stream.close();  // gone without a word
        }
        {
            // Half-closed instead: the peer sees the end inside a frame and closes its side too.
            auto stream = Stream::open(daemon, listener);
            ASSERT_TRUE(stream.send(concat(hello_frame(role_for(listener)), half)));
            stream.shutdown_write();
            stream.frames_until_closed();
            EXPECT_EQ(stream.end(), End::eof) << "connection " << end_name(stream.end());
        }
        {
            // A hello cut short, then the end.
            const Bytes hello = hello_frame(role_for(listener));
            auto stream = Stream::open(daemon, listener);
            ASSERT_TRUE(stream.send(ByteView(hello).first(hello.size() - 3)));
            stream.shutdown_write();
            stream.frames_until_closed();
            EXPECT_EQ(stream.end(), End::eof) << "connection " << end_name(stream.end());
        }
    }
    expect_error_datagram(daemon, half, {});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

// ---------------------------------------------------------------------------------------------
// Hellos that are wrong

TEST(Hostile_test, AHelloWithTheWrongMagicIsRefusedNamingTheMagic) {
    TempDir dir;
    Daemon daemon(dir, "solo");

    for (auto listener : stream_listeners) {
        SCOPED_TRACE(listener_name(listener));
        expect_error_then_close(daemon, listener, raw_hello("HTTP", 1, role_and_node(role_for(listener))),
                                {"magic"});
        expect_error_then_close(daemon, listener, raw_hello("PLX", 1, {}), {});  // too short for the magic
    }
    expect_error_datagram(daemon, raw_hello("HTTP", 1, role_and_node("cli")), {});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, AHelloOfAnotherVersionIsRefusedNamingBothVersions) {
    TempDir dir;
    Daemon daemon(dir, "solo");

    for (auto listener : stream_listeners) {
        SCOPED_TRACE(listener_name(listener));
        expect_error_then_close(daemon, listener, raw_hello("PLXS", 99, role_and_node(role_for(listener))),
                                {"version", "99", std::to_string(proto::protocol_version)});
        // A later version may lay out the rest differently: still answered with the version mismatch.
        expect_error_then_close(daemon, listener,
                                raw_hello("PLXS", proto::protocol_version + 1, {0xff, 0xff, 0xff}),
                                {"version", std::to_string(proto::protocol_version + 1)});
        // Versions are u32: a larger one is refused.
        expect_error_then_close(daemon, listener,
                                raw_hello("PLXS", std::uint64_t{1} << 40, role_and_node("client")),
                                {"version"});
        // A request before any hello.
        expect_error_then_close(daemon, listener, request_frame(1, {{"op", "ping"}}), {"hello"});
    }
    for (auto listener : {Listener::daemon_tcp, Listener::daemon_unix}) {
        SCOPED_TRACE(listener_name(listener));
        expect_error_then_close(daemon, listener, hello_frame("admin"), {"admin"});
        expect_error_then_close(daemon, listener, hello_frame(std::string(65, 'r')),
                                {"role"});  // over 64 bytes
    }
    expect_error_datagram(daemon, raw_hello("PLXS", 99, role_and_node("cli")), {});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

// ---------------------------------------------------------------------------------------------
// Requests that are malformed, or well-formed and wrong

/// Request bodies whose framing is valid but that are not a request.
std::vector<std::pair<std::string, Bytes>> malformed_request_bodies() {
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

TEST(Hostile_test, RequestsThatAreNotRequestsGetAnErrorFrameAndAClose) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);

    for (const auto& [what, body] : malformed_request_bodies()) {
        for (auto listener : stream_listeners) {
            SCOPED_TRACE(listener_name(listener) + ": " + what);
            expect_error_then_close(daemon, listener,
                                    concat(hello_frame(role_for(listener)), raw_request(1, body)),
                                    {"bad request"});
        }
        SCOPED_TRACE(listener_name(Listener::names_udp) + ": " + what);
        expect_error_datagram(daemon, raw_request(1, body), {"bad request"});
    }

    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

/// Sends `body` as request 1 on a fresh session of `listener`, expects a refusal (non-zero code
/// with an "error"), then checks that the same session still answers request 2.
void expect_refusal_and_session_goes_on(const Daemon& daemon, Listener listener, const nlohmann::json& body) {
    SCOPED_TRACE(listener_name(listener) + ": " + body.dump());
    const nlohmann::json harmless =
        listener == Listener::names_tcp ? nlohmann::json{{"op", "ping"}} : nlohmann::json{{"op", "node"}};
    auto stream = Stream::open(daemon, listener);
    ASSERT_TRUE(stream.send(concat(hello_frame(role_for(listener)), request_frame(1, body))));

    auto refusal = stream.reply_to(1);

    ASSERT_TRUE(refusal.has_value()) << "no reply (connection " << end_name(stream.end()) << ")";
    EXPECT_NE(refusal->code, proto::ReplyCode::ok) << refusal->body.dump();
    EXPECT_TRUE(refusal->body.contains("error") && refusal->body["error"].is_string())
        << refusal->body.dump();
    ASSERT_TRUE(stream.send(request_frame(2, harmless)));
    auto next = stream.reply_to(2);
    ASSERT_TRUE(next.has_value()) << "the session stopped answering after the refusal";
    EXPECT_EQ(next->code, proto::ReplyCode::ok);
}

TEST(Hostile_test, AnUnknownOpIsRefusedAndTheSessionGoesOn) {
    TempDir dir;
    Daemon daemon(dir, "solo");

    for (auto listener : stream_listeners) {
        expect_refusal_and_session_goes_on(daemon, listener, {{"op", "frobnicate"}, {"port", "/x"}});
        expect_refusal_and_session_goes_on(daemon, listener, {{"op", ""}});
    }
    Datagrams udp(daemon.names());
    auto answer = udp.exchange(request_frame(1, {{"op", "frobnicate"}}));
    ASSERT_TRUE(answer.has_value());
    ASSERT_EQ(answer->type, FrameType::reply);
    auto reply = proto::decode_reply(answer->fields);
    ASSERT_TRUE(reply.ok());
    EXPECT_EQ(reply->code, proto::ReplyCode::usage);

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, DaemonRequestsWithWrongTypedFieldsAreRefused) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const std::vector<nlohmann::json> bodies{
        {{"op", "open"}, {"port", 42}},
        {{"op", "open"}, {"port", nlohmann::json::array({"/a"})}},
        {{"op", "open"}, {"port", "/typed/policy"}, {"policy", 7}},
        {{"op", "open"}, {"port", "/typed/capacity"}, {"capacity", "big"}},
        {{"op", "close"}, {"handle", "one"}},
        {{"op", "connect"}, {"source", 1}, {"destination", 2}},
        {{"op", "connect"}, {"source", "/a"}, {"destination", "/b"}, {"carrier", 3}},
        {{"op", "stats"}, {"port", "/nobody/here"}, {"forwarded", "yes"}},
        {{"op", "attach"}, {"destination", 9}},
    };

    for (auto listener : {Listener::daemon_unix, Listener::daemon_tcp}) {
        for (const auto& body : bodies)
            expect_refusal_and_session_goes_on(daemon, listener, body);
    }

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

/// Asks the name server `bodies` over TCP (each on its own session) and over UDP: each is refused.
void expect_name_server_refuses(const Daemon& daemon, const std::vector<nlohmann::json>& bodies) {
    for (const auto& body : bodies)
        expect_refusal_and_session_goes_on(daemon, Listener::names_tcp, body);
    Datagrams udp(daemon.names());
    for (const auto& body : bodies) {
        SCOPED_TRACE("UDP: " + body.dump());
        auto answer = udp.exchange(request_frame(1, body));
        ASSERT_TRUE(answer.has_value());
        ASSERT_EQ(answer->type, FrameType::reply);
        auto reply = proto::decode_reply(answer->fields);
        ASSERT_TRUE(reply.ok());
        EXPECT_NE(reply->code, proto::ReplyCode::ok);
    }
}

TEST(Hostile_test, NameServerRequestsWithWrongTypedPortFieldsAreRefused) {
    TempDir dir;
    Daemon daemon(dir, "solo");

    expect_name_server_refuses(daemon, {{{"op", "lookup"}, {"port", 42}},
                                        {{"op", "register_port"}, {"port", 42}},
                                        {{"op", "unregister_port"}, {"port", nlohmann::json::object()}},
                                        {{"op", "add_connection"}, {"source", 1}, {"destination", true}}});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

// Fails until the name server is fixed: NameServer::handle reads "persistent" / "forget" with
// nlohmann's value(key, false), which throws type_error for a non-bool; nothing in NameSession
// catches it, the read loop coroutine dies (co_spawn with asio::detached swallows the exception),
// and the session is left open forever with no reply: the client hangs and the daemon leaks the
// socket (CLOSE-WAIT after the client goes). Not skipped: the test is bounded (3 s per request)
// and uses its own daemon, so it harms no other test.
TEST(Hostile_test, NameServerRequestsWithWrongTypedFlagsAreRefused) {
    TempDir dir;
    Daemon daemon(dir, "solo");

    expect_name_server_refuses(
        daemon, {{{"op", "add_connection"}, {"source", "/a"}, {"destination", "/b"}, {"persistent", "yes"}},
                 {{"op", "remove_connection"}, {"source", "/a"}, {"destination", "/b"}, {"forget", 1}}});

    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

// ---------------------------------------------------------------------------------------------
// A peer that passes the hello and then lies inside a data frame

// Fails until the daemon is fixed: Session::on_data hands the record of a link session (role "link",
// after "attach") to the port without decode_record, so a record whose fields do not decode is
// delivered to the reader (whose read() throws "bad message record") instead of the link getting an
// error frame and a close, as PROTOCOL.md requires for "any frame whose fields do not decode".
TEST(Hostile_test, ALinkThatSendsABrokenRecordIsCutOffAndTheReaderIsUnharmed) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client good({daemon.socket()});
    auto sink = good.open("/victim/sink");
    auto source = good.open("/victim/source");
    ASSERT_EQ(good.connect("/victim/source", "/victim/sink"), "local");
    auto hostile = Stream::tcp(daemon.address());
    // On loopback without a secret a node name is only claimed: the link claims the source's
    // node, so its attach passes (see the next test for one that does not).
    ASSERT_TRUE(hostile.send(concat(proto::encode_hello({proto::protocol_version, "link", "solo"}),
                                    request_frame(1, {{"op", "attach"},
                                                      {"source", "/victim/source"},
                                                      {"destination", "/victim/sink"},
                                                      {"carrier", "tcp"}}))));
    auto attached = hostile.reply_to(1);
    ASSERT_TRUE(attached.has_value());
    ASSERT_EQ(attached->code, proto::ReplyCode::ok) << attached->body.dump();
    // A record whose source declares 200 bytes of which 3 follow: its fields do not decode.
    Bytes broken;
    proto::append_data_frame(broken, 0, Bytes{0xc8, 0x01, '/', 'e', 'v'});

    ASSERT_TRUE(hostile.send(broken));
    const auto frames = hostile.frames_until_closed();
    source.write(Value("fine"));
    std::optional<Received> first;
    EXPECT_NO_THROW(first = sink.read(5s)) << "the broken record reached the reader";

    EXPECT_EQ(hostile.end(), End::eof) << "hostile link " << end_name(hostile.end());
    EXPECT_TRUE(error_reason(frames).has_value()) << "no error frame for a record that does not decode";
    if (!first)
        first = sink.read(5s);  // the read that threw left the good message queued
    ASSERT_TRUE(first.has_value());
    EXPECT_EQ(first->data, Value("fine"));
    EXPECT_EQ(first->envelope.source, "/victim/source");
    EXPECT_TRUE(daemon.process().running());
}

TEST(Hostile_test, ALinkMayNotAttachASourceOfAnotherNode) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client good({daemon.socket()});
    auto sink = good.open("/victim/sink");
    auto source = good.open("/victim/source");
    for (const std::string& forged : {"/victim/source", "/not/registered"}) {
        auto hostile = Stream::tcp(daemon.address());
        ASSERT_TRUE(
            hostile.send(concat(hello_frame("link"), request_frame(1, {{"op", "attach"},
                                                                       {"source", forged},
                                                                       {"destination", "/victim/sink"},
                                                                       {"carrier", "tcp"}}))));
        auto attached = hostile.reply_to(1);
        ASSERT_TRUE(attached.has_value());
        EXPECT_EQ(attached->code, proto::ReplyCode::refused) << attached->body.dump();
        EXPECT_NE(attached->body.value("error", std::string{}).find(forged), std::string::npos)
            << attached->body.dump();
    }
    auto stats = good.stats("/victim/sink");
    EXPECT_TRUE(stats["ports"][0]["inbound"].empty()) << stats.dump();
}

/// Says hello as a client on `stream` and opens `port`: its handle, or nullopt (and a test
/// failure) if that did not work.
std::optional<std::uint64_t> open_raw_port(Stream& stream, const std::string& port) {
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

/// A data_batch frame for `handle` holding one record per source, then `extra` raw bytes appended
/// to the records (and `count` declared: by default the number of sources).
Bytes batch_frame(std::uint64_t handle, const std::vector<std::string>& sources, const Bytes& extra = {},
                  std::optional<std::uint64_t> count = std::nullopt) {
    Bytes records;
    std::uint64_t seq = 1;
    for (const auto& source : sources) {
        Bytes payload;
        nlohmann::json::to_cbor(Value("from " + source), payload);
        proto::append_batch_record(records, source, seq++, 1, payload);
    }
    records.insert(records.end(), extra.begin(), extra.end());
    Bytes frame;
    proto::append_batch_frame_prefix(frame, handle, count.value_or(sources.size()), records.size());
    frame.insert(frame.end(), records.begin(), records.end());
    return frame;
}

TEST(Hostile_test, ABrokenBatchIsRefusedWholeAndTheReaderSeesNoneOfIt) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client good({daemon.socket()});
    auto sink = good.open("/batch/sink");
    using Make = std::function<Bytes(std::uint64_t handle)>;
    const std::vector<std::pair<std::string, Make>> broken_batches = {
        {"a record from another port",
         [](auto h) {
             return batch_frame(h, {"/batch/evil", "/batch/other"});
         }},
        {"fewer records than the count", [](auto h) { return batch_frame(h, {"/batch/evil"}, {}, 3); }},
        {"a record length past the end",
         [](auto h) {
             return batch_frame(h, {"/batch/evil"}, {0x7f, 0x01});
         }},
        {"bytes after the last record", [](auto h) { return batch_frame(h, {"/batch/evil"}, {0x00}); }},
        {"a count of zero", [](auto h) { return batch_frame(h, {}, {}, 0); }},
    };
    for (const auto& [what, make] : broken_batches) {
        SCOPED_TRACE(what);
        auto hostile = Stream::open(daemon, Listener::daemon_unix);
        const auto opened = open_raw_port(hostile, "/batch/evil");
        ASSERT_TRUE(opened.has_value());
        const auto handle = *opened;
        ASSERT_EQ(good.connect("/batch/evil", "/batch/sink"), "local");
        ASSERT_TRUE(hostile.send(make(handle)));
        const auto frames = hostile.frames_until_closed();
        EXPECT_EQ(hostile.end(), End::eof) << end_name(hostile.end());
        EXPECT_TRUE(error_reason(frames).has_value()) << "no error frame for " << what;
        // The port goes with its session; then nothing from the batch may be queued for the reader.
        ASSERT_TRUE(eventually([&] { return !good.lookup("/batch/evil").has_value(); }));
        EXPECT_FALSE(sink.read(std::chrono::milliseconds(0)).has_value()) << "part of a broken batch arrived";
    }
    EXPECT_TRUE(daemon.process().running());
}

// ---------------------------------------------------------------------------------------------
// Shared memory

/// A data_shm frame for `handle` naming a place and a record head from `source`.
Bytes shm_frame(std::uint64_t handle, const proto::ShmPlace& place, const std::string& source) {
    Bytes rest;
    proto::append_shm_place(rest, place, source, 1, 1);
    Bytes frame;
    proto::append_shm_frame_prefix(frame, handle, rest.size());
    frame.insert(frame.end(), rest.begin(), rest.end());
    return frame;
}

TEST(Hostile_test, SharedMemoryFramesThatLieAreRefusedAndOthersAreUnharmed) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client good({daemon.socket()});
    auto sink = good.open("/shm/sink");
    struct Lie {
        std::string what;
        bool with_region;
        std::function<Bytes(std::uint64_t handle, std::uint64_t region, std::uint64_t size)> make;
        std::string reason;
    };
    const std::vector<Lie> lies = {
        {"data_shm without a region", false,
         [](auto h, auto, auto) {
             return shm_frame(h, {1, 0, 10}, "/shm/evil");
         },
         "not the region of handle"},
        {"data_shm naming a region that is not its own", true,
         [](auto h, auto region, auto) {
             return shm_frame(h, {region + 1000, 0, 10}, "/shm/evil");
         },
         "not the region of handle"},
        {"a place running past the region's end", true,
         [](auto h, auto region, auto size) {
             return shm_frame(h, {region, size - 5, 10}, "/shm/evil");
         },
         "outside its region"},
        {"an offset near 2^64", true,
         [](auto h, auto region, auto) {
             return shm_frame(h, {region, ~std::uint64_t{0} - 3, 10}, "/shm/evil");
         },
         "outside its region"},
        {"a record head from another port", true,
         [](auto h, auto region, auto) {
             return shm_frame(h, {region, 0, 10}, "/shm/sink");
         },
         "message from port"},
        {"a release of messages never sent", false,
         [](auto, auto, auto) { return proto::make_shm_number_frame(FrameType::shm_release, 1); },
         "shm_release of 1 messages, but 0 were sent"},
        {"a daemon's own shm_free frame", false,
         [](auto, auto, auto) { return proto::make_shm_free_frame(1, 0); }, "unexpected shm_free frame"},
    };
    for (const auto& lie : lies) {
        SCOPED_TRACE(lie.what);
        auto hostile = Stream::open(daemon, Listener::daemon_unix);
        const auto opened = open_raw_port(hostile, "/shm/evil");
        ASSERT_TRUE(opened.has_value());
        const auto handle = *opened;
        ASSERT_EQ(good.connect("/shm/evil", "/shm/sink"), "local");
        std::uint64_t region = 0;
        std::uint64_t size = 0;
        if (lie.with_region) {
            ASSERT_TRUE(hostile.send(request_frame(2, {{"op", "shm"}, {"handle", handle}})));
            auto given = hostile.reply_to(2);
            ASSERT_TRUE(given.has_value());
            ASSERT_EQ(given->code, proto::ReplyCode::ok) << given->body.dump();
            region = given->body["region"].get<std::uint64_t>();
            size = given->body["size"].get<std::uint64_t>();
        }
        ASSERT_TRUE(hostile.send(lie.make(handle, region, size)));
        const auto frames = hostile.frames_until_closed();
        EXPECT_EQ(hostile.end(), End::eof) << end_name(hostile.end());
        const auto reason = error_reason(frames);
        ASSERT_TRUE(reason.has_value()) << "no error frame";
        EXPECT_NE(reason->find(lie.reason), std::string::npos) << *reason;
        ASSERT_TRUE(eventually([&] { return !good.lookup("/shm/evil").has_value(); }));
        EXPECT_FALSE(sink.read(std::chrono::milliseconds(0)).has_value()) << "a lie reached the reader";
    }
    EXPECT_TRUE(daemon.process().running());
    EXPECT_EQ(good.stats()["daemon"]["shm_regions"], 0) << "a region outlived the session that lied";
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, AReaderThatNeverReleasesSharedMemoryIsCutOffAndTheSlotsComeBack) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client good({daemon.socket()});
    // The reader maps regions, reads every frame and never releases one.
    auto reader = Stream::open(daemon, Listener::daemon_unix);
    ASSERT_TRUE(reader.send(
        concat(hello_frame("client"), concat(request_frame(1, {{"op", "shm"}}),
                                             request_frame(2, {{"op", "open"}, {"port", "/lent/sink"}})))));
    ASSERT_TRUE(reader.reply_to(2).has_value());
    // The writer names the same slot again and again: the daemon does not track the writer's use of
    // its own region, so only the reader's bound stops the references piling up.
    auto writer = Stream::open(daemon, Listener::daemon_unix);
    const auto opened = open_raw_port(writer, "/lent/source");
    ASSERT_TRUE(opened.has_value());
    const auto handle = *opened;
    ASSERT_EQ(good.connect("/lent/source", "/lent/sink"), "local");
    ASSERT_TRUE(writer.send(request_frame(2, {{"op", "shm"}, {"handle", handle}})));
    auto given = writer.reply_to(2);
    ASSERT_TRUE(given.has_value());
    const auto region = given->body["region"].get<std::uint64_t>();

    std::thread reading([&] { reader.frames_until_closed(Clock::now() + 120s); });
    const Bytes one = shm_frame(handle, {region, 0, 10}, "/lent/source");
    Bytes many;
    for (int i = 0; i < 4096; ++i)
        many.insert(many.end(), one.begin(), one.end());
    const std::size_t rounds = (std::size_t{1} << 18) / 4096 + 2;
    for (std::size_t i = 0; i < rounds; ++i) {
        if (!writer.send(many, Clock::now() + 60s))
            break;
    }
    reading.join();

    EXPECT_NE(reader.end(), End::timeout) << "the reader holding every slot reference was not cut off";
    writer.close();
    EXPECT_TRUE(eventually([&] { return good.stats()["daemon"]["shm_slots"] == 0; }))
        << "slot references outlived the reader that held them";
    EXPECT_TRUE(daemon.process().running());
}

TEST(Hostile_test, AMalformedShmRequestLeavesNoHalfMadeRegionBehind) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    auto hostile = Stream::open(daemon, Listener::daemon_unix);
    const auto opened = open_raw_port(hostile, "/half/evil");
    ASSERT_TRUE(opened.has_value());
    const auto handle = *opened;
    ASSERT_TRUE(hostile.send(request_frame(2, {{"op", "shm"}, {"handle", handle}, {"bytes", "many"}})));
    auto refused = hostile.reply_to(2);
    ASSERT_TRUE(refused.has_value());
    EXPECT_NE(refused->code, proto::ReplyCode::ok);

    ASSERT_TRUE(hostile.send(shm_frame(handle, {1, 0, 10}, "/half/evil")));
    const auto reason = error_reason(hostile.frames_until_closed());

    ASSERT_TRUE(reason.has_value());
    EXPECT_NE(reason->find("not the region of handle"), std::string::npos) << *reason;
    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, APayloadInSharedMemoryLargerThanAFrameIsRefused) {
    TempDir dir;
    const auto config = dir.file("plexusd.json");
    std::ofstream(config) << R"({"max_frame": 1048576})";
    Daemon daemon(dir, "solo", "", {"--config", config});
    auto hostile = Stream::open(daemon, Listener::daemon_unix);
    const auto opened = open_raw_port(hostile, "/big/evil");
    ASSERT_TRUE(opened.has_value());
    const auto handle = *opened;
    ASSERT_TRUE(hostile.send(request_frame(2, {{"op", "shm"}, {"handle", handle}, {"bytes", 1048576}})));
    auto given = hostile.reply_to(2);
    ASSERT_TRUE(given.has_value());
    ASSERT_EQ(given->code, proto::ReplyCode::ok);
    EXPECT_GE(given->body["size"].get<std::uint64_t>(), 4u * 1048576u);

    ASSERT_TRUE(hostile.send(shm_frame(handle, {given->body["region"], 0, 2 * 1048576}, "/big/evil")));
    const auto reason = error_reason(hostile.frames_until_closed());

    ASSERT_TRUE(reason.has_value());
    EXPECT_NE(reason->find("exceeds the frame limit"), std::string::npos) << *reason;
}

TEST(Hostile_test, AWriterThatNeverReadsItsFreesIsHeldBack) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    auto writer = Stream::open(daemon, Listener::daemon_unix);
    const auto opened = open_raw_port(writer, "/frees/evil");
    ASSERT_TRUE(opened.has_value());
    const auto handle = *opened;
    ASSERT_TRUE(writer.send(request_frame(2, {{"op", "shm"}, {"handle", handle}})));
    auto given = writer.reply_to(2);
    ASSERT_TRUE(given.has_value());
    const Bytes one = shm_frame(handle, {given->body["region"], 0, 10}, "/frees/evil");
    Bytes many;
    for (int i = 0; i < 4096; ++i)
        many.insert(many.end(), one.begin(), one.end());

    // Each message goes to nobody and is done with at once: a shm_free frame for the writer, who
    // never reads. Unbounded, 1,000 rounds would queue four million of them in the daemon.
    int rounds = 0;
    while (rounds < 1000 && writer.send(many, Clock::now() + 2s))
        ++rounds;

    EXPECT_LT(rounds, 1000) << "the daemon kept reading a writer that leaves its frees unread";
    EXPECT_TRUE(daemon.process().running());
    expect_everyone_still_served(daemon);
}

TEST(Hostile_test, SharedMemoryIsOnlyForClientsOnTheUnixSocket) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    auto remote = Stream::open(daemon, Listener::daemon_tcp);
    ASSERT_TRUE(remote.send(concat(hello_frame("client"), request_frame(1, {{"op", "shm"}}))));
    auto reply = remote.reply_to(1);
    ASSERT_TRUE(reply.has_value());
    EXPECT_EQ(reply->code, proto::ReplyCode::refused);
    EXPECT_NE(reply->body.value("error", std::string()).find("Unix socket"), std::string::npos)
        << reply->body.dump();
}

// ---------------------------------------------------------------------------------------------
// Everyone else

/// Every attack above, once, on every listener.
void attack_everything(const Daemon& daemon) {
    std::mt19937 random(7);
    std::vector<Bytes> attacks;
    for (auto length : lying_lengths) {
        attacks.push_back(lying_header(length));
        attacks.push_back(concat(hello_frame("client"), lying_header(length)));
    }
    for (std::size_t size : {1, 100, 60000})
        attacks.push_back(random_bytes(size, random));
    const Bytes whole = request_frame(1, {{"op", "ping"}});
    attacks.push_back(concat(hello_frame("client"), Bytes(whole.begin(), whole.begin() + 3)));
    attacks.push_back(raw_hello("HTTP", 1, role_and_node("client")));
    attacks.push_back(raw_hello("PLXS", 99, role_and_node("client")));
    for (const auto& [what, body] : malformed_request_bodies()) {
        attacks.push_back(concat(hello_frame("client"), raw_request(1, body)));
    }

    // Bounded as a whole: a daemon that hung on every connection fails the test, in seconds.
    const auto deadline = Clock::now() + 15s;
    for (const auto& attack : attacks) {
        for (auto listener : stream_listeners) {
            auto stream = Stream::open(daemon, listener);
            stream.send(attack, deadline);
            stream.shutdown_write();
            stream.frames_until_closed(std::min(deadline, Clock::now() + exchange_timeout));
            EXPECT_NE(stream.end(), End::timeout)
                << listener_name(listener) << " kept a hostile connection open";
        }
        Datagrams udp(daemon.names());
        udp.send(ByteView(attack).first(std::min<std::size_t>(attack.size(), 65507)));
        EXPECT_TRUE(udp.receive(std::min(deadline, Clock::now() + exchange_timeout)).has_value())
            << "no answer over UDP";
    }
}

TEST(Hostile_test, AfterTheAttackTheDaemonStillServesOldAndNewClients) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client before({daemon.socket()});
    auto held = before.open("/before/held");
    const long rss_before = daemon.rss_kib();
    ASSERT_GT(rss_before, 0);

    attack_everything(daemon);

    EXPECT_LT(daemon.rss_kib() - rss_before, max_rss_growth_kib);
    ASSERT_TRUE(daemon.process().running()) << daemon.process().err();
    // The client that was connected before the attack opens ports, connects and reads its data.
    auto sink = before.open("/before/sink");
    auto source = before.open("/before/source");
    EXPECT_EQ(before.connect("/before/source", "/before/sink"), "local");
    source.write(Value{{"after", "attack"}});
    auto message = sink.read(5s);
    ASSERT_TRUE(message.has_value());
    EXPECT_EQ(message->data, (Value{{"after", "attack"}}));
    // New clients: the CLI writes and reads through the daemon, and lists through the name server.
    auto reader =
        start_cli(dir, daemon, {"read", "/after/sink", "--count", "1", "--timeout", "10"}, "reader");
    ASSERT_TRUE(wait_port(dir, daemon, "/after/sink"));
    auto written = run_cli(dir, daemon, {"write", "/after/source", "/after/sink"}, "42\n");
    EXPECT_EQ(written.status, 0) << written.err;
    ASSERT_EQ(reader->wait(10s), 0) << reader->err();
    EXPECT_EQ(reader->out(), "42\n");
    auto listed = run_cli(dir, daemon, {"list"});
    EXPECT_EQ(listed.status, 0) << listed.err;
    EXPECT_NE(listed.out.find("/before/held"), std::string::npos) << listed.out;
    auto names_list = Client::ask_names(daemon.names(), {{"op", "list"}});
    ASSERT_TRUE(names_list.has_value());
    EXPECT_NE(names_list->dump().find("/before/sink"), std::string::npos) << names_list->dump();
    expect_everyone_still_served(daemon);
    EXPECT_TRUE(daemon.process().running());
}

}  // namespace
}  // namespace plexus::test
