#include "tcp_handshake.hpp"

#include <poll.h>
#include <sys/socket.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <optional>

#include "plexus/client.hpp"
#include "plexus/proto/auth.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/hello.hpp"
#include "plexus/proto/identity.hpp"

namespace plexus::detail {

namespace {

/// Reads frames from a blocking socket one at a time, never past the frame it returns... except
/// what one recv brings: the peer sends nothing unasked after its hello and proof, so nothing is
/// lost here (anything extra is a protocol error).
class FrameFeed {
public:
    FrameFeed(int fd, TlsChannel* tls, std::string address, std::chrono::steady_clock::time_point deadline)
        : fd_(fd), tls_(tls), address_(std::move(address)), deadline_(deadline) {}

    /// The next frame's type and fields (copied).
    std::pair<proto::FrameType, proto::Bytes> next() {
        const proto::FrameDecoder decoder(64 * 1024);
        for (;;) {
            const auto decoded = decoder.decode(buffer_);
            if (decoded.status == proto::DecodeStatus::frame) {
                proto::Bytes fields(decoded.fields.begin(), decoded.fields.end());
                const auto type = decoded.type;
                buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(decoded.used));
                return {type, std::move(fields)};
            }
            if (decoded.status == proto::DecodeStatus::bad)
                throw Error(ErrorCode::refused, address_ + " is not a Plexus peer: " + decoded.error);
            receive();
        }
    }
    bool empty() const { return buffer_.empty(); }

private:
    void receive() {
        std::uint8_t chunk[4096];
        if (tls_) {
            const ssize_t n = tls_->receive_by(chunk, sizeof chunk, deadline_);
            if (n == 0)
                throw Error(ErrorCode::refused, address_ + " closed the connection during the hello");
            if (n < 0 && errno == EAGAIN)
                throw Error(ErrorCode::timeout, "no hello from " + address_ + " in time");
            if (n < 0)
                throw Error(ErrorCode::refused, "reading from " + address_ + ": " + tls_->failure());
            buffer_.insert(buffer_.end(), chunk, chunk + n);
            return;
        }
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline_ - std::chrono::steady_clock::now());
        pollfd ready{fd_, POLLIN, 0};
        if (left.count() <= 0 || ::poll(&ready, 1, static_cast<int>(left.count())) <= 0)
            throw Error(ErrorCode::timeout, "no hello from " + address_ + " in time");
        const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
        if (n == 0)
            throw Error(ErrorCode::refused, address_ + " closed the connection during the hello");
        if (n < 0 && errno != EINTR)
            throw Error(ErrorCode::refused, "reading from " + address_ + ": " + std::strerror(errno));
        if (n > 0)
            buffer_.insert(buffer_.end(), chunk, chunk + n);
    }

    int fd_;
    TlsChannel* tls_;
    std::string address_;
    std::chrono::steady_clock::time_point deadline_;
    proto::Bytes buffer_;
};

void send_all(int fd, const proto::Bytes& bytes, const std::string& address) {
    std::size_t sent = 0;
    while (sent < bytes.size()) {
        const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            throw Error(ErrorCode::refused, "sending to " + address + ": " + std::strerror(errno));
        sent += static_cast<std::size_t>(n);
    }
}

/// A frame that is not what was expected: the peer's error frame says why it refused us.
[[noreturn]] void refused_by(const std::string& address, proto::FrameType type, const proto::Bytes& fields,
                             const char* expected) {
    if (type == proto::FrameType::error) {
        const auto reason = proto::decode_error(fields);
        throw Error(ErrorCode::refused,
                    address + " refused: " + (reason ? *reason : std::string("(no reason)")));
    }
    throw Error(ErrorCode::refused, address + " sent " +
                                        proto::frame_type_name(static_cast<std::uint8_t>(type)) + " where " +
                                        expected + " was expected");
}

}  // namespace

TcpGreeting tcp_handshake(int fd, const std::string& address, const std::string& expected_role,
                          std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    const auto secret = secret_from_environment();
    TcpGreeting greeting;
    if (secret)
        greeting.tls = std::make_unique<TlsChannel>(fd, *secret, address, deadline);
    proto::Hello mine{proto::protocol_version, "client", ""};
    mine.has_secret = secret.has_value();
    const auto hello_frame = proto::encode_hello(mine);
    if (greeting.tls)
        greeting.tls->send_all(hello_frame.data(), hello_frame.size(), deadline);
    else
        send_all(fd, hello_frame, address);
    FrameFeed feed(fd, greeting.tls.get(), address, deadline);
    auto [type, fields] = feed.next();
    if (type != proto::FrameType::hello)
        refused_by(address, type, fields, "a hello");
    auto hello = proto::decode_hello(fields);
    if (!hello)
        throw Error(ErrorCode::refused, address + " sent a bad hello: " + hello.error().message);
    if (!feed.empty())
        throw Error(ErrorCode::refused, address + " sent frames before it was asked anything");
    if (hello->role != expected_role) {
        const auto said = [](const std::string& role) {
            return role == "names" ? std::string("name server") : role;
        };
        throw Error(ErrorCode::refused,
                    address + " is a " + said(hello->role) + ", not a " + said(expected_role) +
                        (expected_role == "names" ? " (PLEXUS_NAMES or --names must give a "
                                                    "name server's address)"
                                                  : ""));
    }
    if (greeting.tls && secret->identity()) {
        // As a daemon checks its peers (FramedConnection): a name server shows a name server's
        // certificate, a daemon its own node's.
        const auto subject = greeting.tls->peer_subject();
        const bool names = subject && subject->kind == proto::Subject::Kind::names;
        const std::string shown = subject ? subject->text() : std::string("no Plexus certificate");
        if (!subject || (hello->role == "names") != names)
            throw Error(ErrorCode::refused,
                        address + " says it is a " + hello->role + ", but shows the certificate of " + shown);
        if (!names && !hello->node.empty() && hello->node != subject->name)
            throw Error(ErrorCode::refused, address + " says it is node '" + hello->node +
                                                "', but shows the certificate of " + shown);
    }
    greeting.peer_max_frame = hello->max_frame;
    return greeting;
}

std::optional<proto::Secret> secret_from_environment() {
    const char* path = std::getenv("PLEXUS_SECRET_FILE");
    if (!path || !*path) {
        if (const char* identity = std::getenv("PLEXUS_IDENTITY"); identity && *identity)
            throw Error(ErrorCode::usage,
                        "PLEXUS_IDENTITY needs the deployment secret too (PLEXUS_SECRET_FILE): identities "
                        "come on top of it");
        return std::nullopt;
    }
    auto secret = proto::Secret::load(path);
    if (!secret)
        throw Error(ErrorCode::usage, secret.error().message);
    auto identity = proto::identity_from_environment();
    if (!identity)
        throw Error(ErrorCode::usage, identity.error().message);
    if (*identity)
        secret->set_identity(**identity);
    return *secret;
}

}  // namespace plexus::detail
