#include "framed_connection.hpp"

#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <array>

#include <cerrno>
#include <cstring>

#include <spdlog/spdlog.h>

#include "call_table.hpp"
#include "packet_marks.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/tls_psk.hpp"
#include "tls_context.hpp"

namespace plexus::daemon {

namespace {
// A batch of frames gathered into one write; larger batches gain nothing measurable.
constexpr std::size_t write_budget = 256 * 1024;
// A record this large makes a connection ask for a large send buffer.
constexpr std::size_t large_message = 256 * 1024;
constexpr int large_message_send_buffer = 4 * 1024 * 1024;
// How long a closing connection waits for its peer before cutting it off.
constexpr auto close_grace = std::chrono::seconds(2);
// How often a link between identities looks whether its peer's certificate was revoked since its
// handshake: a stat of crl.pem each time, the list read again only when it changed.
constexpr auto revocation_check_interval = std::chrono::seconds(1);
}  // namespace

FramedConnection::FramedConnection(Socket socket, std::size_t max_frame, std::function<void()> on_space)
    : stream_(std::move(socket)),
      socket_(stream_.socket()),
      reader_(max_frame),
      outbox_(std::move(on_space)),
      wake_(socket_.get_executor()),
      hello_signal_(socket_.get_executor()) {}

void FramedConnection::require_secret(std::optional<proto::Secret> secret, proto::Party party) {
    secret_ = std::move(secret);
    party_ = party;
    tls_ = secret_ ? TlsContext::of(*secret_) : nullptr;
}

void FramedConnection::start(const proto::Hello& mine) {
    outbox_.set_owner(weak_from_this());
    mine_ = mine;
    mine_.has_secret = secret_.has_value();
    needs_tls_ = secret_.has_value() && !is_local();
    auto self = shared_from_this();
    asio::co_spawn(
        executor(), [self] { return self->begin(); }, asio::detached);
    if (handshake_timeout_.count() > 0) {
        asio::co_spawn(
            executor(), [self] { return self->watch_handshake(); }, asio::detached);
    }
}

Task<void> FramedConnection::begin() {
    auto self = shared_from_this();
    if (needs_tls_ && !co_await secure_link())
        co_return;
    if (closed_)
        co_return;
    if (stream_.peer_certificate() && secret_->identity()) {
        asio::co_spawn(
            executor(), [self] { return self->watch_revocation(); }, asio::detached);
    }
    // A plain peer where TLS is needed hears only why it is refused: not even our node's name.
    if (!needs_tls_ || stream_.encrypted())
        send(proto::encode_hello(mine_));
    asio::co_spawn(
        executor(), [self] { return self->read_loop(); }, asio::detached);
    asio::co_spawn(
        executor(), [self] { return self->write_loop(); }, asio::detached);
}

Task<bool> FramedConnection::secure_link() {
    const bool accepting = party_ == proto::Party::accepting;
    std::array<std::uint8_t, 2> first{};
    if (accepting) {
        auto [error, n] = co_await asio::async_read(socket_, asio::buffer(first), use_nothrow);
        if (closed_)
            co_return false;
        if (error) {
            close(error == asio::error::eof ? "peer closed before its handshake" : error.message());
            co_return false;
        }
        if (!proto::starts_tls(first[0], first[1])) {
            stream_.give_back(first);  // read as frames, and refused in words (take_hello)
            co_return true;
        }
    }
    const auto secured =
        co_await stream_.start_tls(*tls_, accepting, accepting ? proto::ByteView(first) : proto::ByteView());
    if (closed_)
        co_return false;
    if (!secured) {
        co_await refuse_unauthenticated(
            secured.error().message +
                (secret_->identity()
                     ? " (the peer shows no valid certificate of this deployment's CA, or runs without an "
                       "identity)"
                     : " (the peer does not hold this deployment's secret, or runs without one)"),
            false);
        co_return false;
    }
    co_return true;
}

Task<void> FramedConnection::watch_handshake() {
    auto self = shared_from_this();
    if (co_await wait_for_hello(handshake_timeout_) || closed_)
        co_return;
    on_handshake_timeout();
    spdlog::warn("{}: no {} within {} ms of connecting: cut off", description_,
                 needs_tls_ ? "TLS handshake and hello" : "hello", handshake_timeout_.count());
    close("no handshake within " + std::to_string(handshake_timeout_.count()) + " ms");
}

Task<void> FramedConnection::watch_revocation() {
    auto self = shared_from_this();
    asio::steady_timer timer(executor());
    while (!closed_) {
        timer.expires_after(revocation_check_interval);
        co_await timer.async_wait(use_nothrow);
        if (closed_)
            co_return;
        if (proto::revoked_now(*secret_->identity(), stream_.peer_certificate())) {
            spdlog::warn(
                "{}: the certificate of {} was revoked after this link was made (crl.pem changed): "
                "link closed",
                description_, peer_subject() ? peer_subject()->text() : std::string("the peer"));
            close("the peer's certificate was revoked");
            co_return;
        }
    }
}

void FramedConnection::send(proto::Bytes frame) {
    if (closed_)
        return;
    outbox_.push_control(std::move(frame));
    wake_.notify();
}

void FramedConnection::close(const std::string& reason) {
    if (closed_)
        return;
    closed_ = true;
    boost::system::error_code ignored;
    socket_.shutdown(Socket::shutdown_both, ignored);
    socket_.close(ignored);
    if (rings_)
        rings_->close();    // ends a wait in the rings
    outbox_.release_all();  // the peer will not release them: free the writers' slots now
    wake_.notify();
    hello_signal_.notify();
    on_closed(reason);
    peer_ticket_.reset();  // the peer may connect again in its place
    if (auto calls = std::move(calls_))
        calls->closed(*this);  // after on_closed: a session's ports are gone by then
}

void FramedConnection::close_when_drained() {
    if (closed_ || draining_)
        return;
    draining_ = true;
    wake_.notify();
    auto self = shared_from_this();
    asio::co_spawn(
        executor(), [self] { return self->close_after(close_grace); }, asio::detached);
}

void FramedConnection::fail(const std::string& reason) {
    if (closed_)
        return;
    spdlog::warn("{}: {}", description_, reason);
    send(proto::make_error_frame(reason));
    close_when_drained();
}

bool FramedConnection::is_local() {
    boost::system::error_code ignored;
    return socket_.local_endpoint(ignored).protocol().family() == AF_UNIX;
}

void FramedConnection::limit_send_buffer(int bytes) {
    boost::system::error_code ignored;
    socket_.set_option(asio::socket_base::send_buffer_size(bytes), ignored);
    large_send_buffer_ = true;  // never raised again
}

proto::Status FramedConnection::mark_packets(int dscp) {
    boost::system::error_code ec;
    const int family = socket_.local_endpoint(ec).protocol().family();
    if (ec)
        return proto::Error{"cannot mark packets: " + ec.message()};
    return mark_socket(socket_.native_handle(), family, dscp);
}

namespace {
std::optional<asio::ip::address> ip_of(const sockaddr_storage& address) {
    if (address.ss_family == AF_INET) {
        const auto* v4 = reinterpret_cast<const sockaddr_in*>(&address);
        return asio::ip::address_v4(ntohl(v4->sin_addr.s_addr));
    }
    if (address.ss_family == AF_INET6) {
        const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&address);
        asio::ip::address_v6::bytes_type bytes;
        std::memcpy(bytes.data(), v6->sin6_addr.s6_addr, bytes.size());
        return asio::ip::address_v6(bytes, v6->sin6_scope_id);
    }
    return std::nullopt;
}
}  // namespace

std::optional<asio::ip::address> FramedConnection::remote_ip() {
    sockaddr_storage peer{};
    socklen_t size = sizeof peer;
    if (::getpeername(socket_.native_handle(), reinterpret_cast<sockaddr*>(&peer), &size) != 0)
        return std::nullopt;
    return ip_of(peer);
}

std::optional<asio::ip::address> FramedConnection::local_ip() {
    sockaddr_storage local{};
    socklen_t size = sizeof local;
    if (::getsockname(socket_.native_handle(), reinterpret_cast<sockaddr*>(&local), &size) != 0)
        return std::nullopt;
    return ip_of(local);
}

bool FramedConnection::peer_hung_up() {
    if (closed_)
        return true;
    pollfd state{socket_.native_handle(), POLLRDHUP, 0};
    return ::poll(&state, 1, 0) > 0 && (state.revents & (POLLRDHUP | POLLHUP | POLLERR)) != 0;
}

Task<bool> FramedConnection::wait_for_hello(std::chrono::steady_clock::duration timeout) {
    auto self = shared_from_this();
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!peer_hello_ && !closed_) {
        const auto now = std::chrono::steady_clock::now();
        if (now >= deadline)
            break;
        co_await hello_signal_.wait_for(deadline - now);
    }
    co_return peer_hello_.has_value() && !closed_;
}

Task<void> FramedConnection::close_after(std::chrono::steady_clock::duration grace) {
    auto self = shared_from_this();
    asio::steady_timer timer(executor(), grace);
    co_await timer.async_wait(use_nothrow);
    close("closed after drain");
}

Task<void> FramedConnection::read_loop() {
    auto self = shared_from_this();
    while (!closed_) {
        ReadOutcome outcome = reader_.try_next();
        // Not `rings_ ? co_await ... : co_await ...`: GCC 12 got that conditional wrong (it
        // awaited the rings' read with no rings).
        if (!outcome.frame && !outcome.protocol_error && rings_)
            outcome = co_await reader_.next(*rings_);
        else if (!outcome.frame && !outcome.protocol_error)
            outcome = co_await reader_.next(stream_);
        if (closed_)
            break;
        if (!outcome.frame) {
            if (outcome.tls_refused) {
                // Nothing can be told to a peer whose stream is broken: close, say why, count.
                spdlog::warn("{}: {} (someone on the path altered, injected or replayed bytes?)",
                             description_, outcome.error);
                on_tls_refused(outcome.error);
                close(outcome.error);
            } else if (outcome.protocol_error) {
                on_protocol_error();
                fail(outcome.error);
            } else {
                close(outcome.clean_close ? "peer closed" : outcome.error);
            }
            break;
        }
        InFrame& frame = *outcome.frame;
        if (frame.type == proto::FrameType::error) {
            // The reason is a string field (length, then text); a reason that does not decode is
            // shown as the bytes that came.
            const auto reason = proto::decode_error(frame.fields);
            close("peer reported an error: " +
                  (reason ? *reason : std::string(proto::as_string_view(frame.fields))));
            break;
        }
        if (!peer_hello_) {
            if (!co_await take_hello(frame))
                break;
            continue;
        }
        const FrameAction action = on_frame_now(frame);
        if (action == FrameAction::handled)
            continue;
        if (action == FrameAction::stop)
            break;
        if (!co_await on_frame(std::move(frame)))
            break;
    }
    if (draining_ && !closed_)
        co_await discard_until_peer_closes();
}

Task<void> FramedConnection::discard_until_peer_closes() {
    std::array<std::uint8_t, 4096> scratch{};
    while (!closed_) {
        auto [error, n] = co_await stream_.read_some(asio::buffer(scratch));
        if (closed_)
            co_return;
        if (error) {
            close(error == asio::error::eof ? "peer closed after the error" : error.message());
            co_return;
        }
    }
}

Task<bool> FramedConnection::take_hello(InFrame& frame) {
    if (frame.type != proto::FrameType::hello) {
        fail("expected a hello frame first, got " +
             proto::frame_type_name(static_cast<std::uint8_t>(frame.type)));
        co_return false;
    }
    auto hello = proto::decode_hello(frame.fields);
    if (!hello) {
        fail("bad hello: " + hello.error().message);
        co_return false;
    }
    if (hello->version != proto::protocol_version) {
        fail("protocol version " + std::to_string(hello->version) + " is not supported (this daemon speaks " +
             std::to_string(proto::protocol_version) + ")");
        co_return false;
    }
    if (needs_tls_ && !stream_.encrypted()) {
        co_await refuse_unauthenticated(
            hello->has_secret
                ? "authentication required: this deployment encrypts its TCP links and the peer did not "
                  "start TLS (a Plexus older than this one?)"
                : "authentication required: this deployment has a shared secret and the peer offered none "
                  "(start it with --secret-file FILE or PLEXUS_SECRET_FILE)");
        co_return false;
    }
    if (auto mismatch = certificate_mismatch(*hello)) {
        co_await refuse_unauthenticated(*mismatch, true);
        co_return false;
    }
    co_return accept_peer(std::move(*hello));
}

std::optional<std::string> FramedConnection::certificate_mismatch(const proto::Hello& hello) const {
    if (!secret_ || !secret_->identity() || !stream_.encrypted())
        return std::nullopt;
    const auto& subject = peer_subject();
    if (!subject)
        return "the peer's certificate names no Plexus node or name server";
    const bool names = subject->kind == proto::Subject::Kind::names;
    if (hello.role == "names" && !names)
        return "the peer says it is a name server, but its certificate is that of " + subject->text();
    if (hello.role == "daemon" && names)
        return "the peer says it is a daemon, but its certificate is that of " + subject->text();
    if (!names && !hello.node.empty() && hello.node != subject->name)
        return "the peer says it is node '" + hello.node + "', but its certificate is that of " +
               subject->text();
    return std::nullopt;
}

bool FramedConnection::accept_peer(proto::Hello hello) {
    if (auto accepted = on_hello(hello); !accepted) {
        fail(accepted.error().message);
        return false;
    }
    peer_hello_ = std::move(hello);
    if (peer_ticket_)
        peer_ticket_->handshake_done();
    hello_signal_.notify();
    return true;
}

Task<void> FramedConnection::refuse_unauthenticated(std::string reason, bool can_tell) {
    auto self = shared_from_this();
    spdlog::warn("{}: {}", description_, reason);
    on_auth_failure(reason);
    if (peer_ticket_)
        peer_ticket_->proof_failed();
    // Every failed attempt costs the peer this long: no fast guessing, whatever it tries.
    constexpr auto failure_pause = std::chrono::seconds(1);
    asio::steady_timer pause(executor(), failure_pause);
    co_await pause.async_wait(use_nothrow);
    if (can_tell)
        fail(reason);
    else
        close(reason);  // a failed TLS handshake has told the peer (its alert); no frame could follow
}

bool FramedConnection::use_rings(std::unique_ptr<SessionRings> rings, proto::Bytes answer) {
    if (reader_.buffered() > 0) {
        fail("frames on the socket after the rings request");
        return false;
    }
    rings_ = std::move(rings);
    outbox_.push_rings_answer(std::move(answer), rings_->client_descriptors(), rings_);
    wake_.notify();
    auto self = shared_from_this();
    asio::co_spawn(
        executor(), [self] { return self->watch_socket(); }, asio::detached);
    return true;
}

Task<void> FramedConnection::watch_socket() {
    auto self = shared_from_this();
    while (!closed_) {
        auto [ec] = co_await socket_.async_wait(Socket::wait_read, use_nothrow);
        if (closed_)
            co_return;
        if (ec) {
            close(ec.message());
            co_return;
        }
        std::uint8_t byte = 0;
        const ssize_t n = ::recv(socket_.native_handle(), &byte, 1, MSG_DONTWAIT);
        if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
            // What the peer wrote into the ring before it closed is still read, then the reader
            // sees the end of the stream.
            rings_->peer_closed();
            co_return;
        }
        if (n > 0) {
            on_protocol_error();
            fail("bytes on the socket after the session moved to shared-memory rings");
            co_return;
        }
    }
}

Task<proto::Status> FramedConnection::send_descriptors(const std::vector<int>& fds) {
    std::uint8_t marker = 0;
    const std::vector<iovec> piece{{&marker, 1}};
    const auto sent = co_await send_with_fds(piece, fds);
    if (!sent)
        co_return sent.error();
    co_return proto::Ok{};
}

Task<proto::Result<std::size_t>> FramedConnection::send_with_fds(const Batch& batch) {
    std::vector<iovec> pieces;
    pieces.reserve(batch.buffers.size());
    for (const auto& buffer : batch.buffers)
        pieces.push_back({const_cast<void*>(buffer.data()), buffer.size()});
    co_return co_await send_with_fds(pieces, batch.fds);
}

Task<proto::Result<std::size_t>> FramedConnection::send_with_fds(const std::vector<iovec>& pieces,
                                                                 const std::vector<int>& fds) {
    std::vector<char> control(CMSG_SPACE(sizeof(int) * fds.size()));
    msghdr message{};
    message.msg_iov = const_cast<iovec*>(pieces.data());
    message.msg_iovlen = pieces.size();
    message.msg_control = control.data();
    message.msg_controllen = control.size();
    cmsghdr* header = CMSG_FIRSTHDR(&message);
    header->cmsg_level = SOL_SOCKET;
    header->cmsg_type = SCM_RIGHTS;
    header->cmsg_len = CMSG_LEN(sizeof(int) * fds.size());
    std::memcpy(CMSG_DATA(header), fds.data(), sizeof(int) * fds.size());
    for (;;) {
        const ssize_t n = ::sendmsg(socket_.native_handle(), &message, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n >= 0)
            co_return static_cast<std::size_t>(n);
        if (errno == EINTR)
            continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK)
            co_return proto::Error{std::string("sending region descriptors: ") + std::strerror(errno)};
        auto [ec] = co_await socket_.async_wait(Socket::wait_write, use_nothrow);
        if (ec)
            co_return proto::Error{ec.message()};
        if (closed_)
            co_return proto::Error{"closed"};
    }
}

void FramedConnection::consume(std::vector<asio::const_buffer>& buffers, std::size_t sent) {
    std::size_t whole = 0;
    while (whole < buffers.size() && sent >= buffers[whole].size()) {
        sent -= buffers[whole].size();
        ++whole;
    }
    buffers.erase(buffers.begin(), buffers.begin() + static_cast<std::ptrdiff_t>(whole));
    if (!buffers.empty())
        buffers.front() += sent;
}

Task<void> FramedConnection::write_loop() {
    auto self = shared_from_this();
    Batch batch;
    while (!closed_) {
        if (outbox_.empty()) {
            if (draining_) {
                boost::system::error_code ignored;
                socket_.shutdown(Socket::shutdown_send, ignored);
                co_return;  // the reader sees the peer's close, or close_after cuts it off
            }
            co_await wake_.wait();
            continue;
        }
        batch.clear();
        outbox_.fill(batch, write_budget);
        if (outbox_.lent() > Outbox::max_lent) {
            const std::string why =
                "more than " + std::to_string(Outbox::max_lent) + " shared-memory messages not released";
            spdlog::warn("{}: {}", description_, why);
            close(why);  // at once: what is queued for a peer this broken would not be read either
            co_return;
        }
        if (batch.largest >= large_message && !large_send_buffer_) {
            // Large messages leave a Unix socket in a few system calls with a larger buffer (the
            // kernel caps it at net.core.wmem_max); streams of small ones keep the default, so that
            // fewer of them wait in the socket under load. TCP tunes its buffers itself: setting
            // one would turn that off.
            large_send_buffer_ = true;
            boost::system::error_code ignored;
            if (socket_.local_endpoint(ignored).protocol().family() == AF_UNIX)
                socket_.set_option(asio::socket_base::send_buffer_size(large_message_send_buffer), ignored);
        }
        if (writing_rings_) {
            // Descriptors first, on the socket: the frames naming them follow in the ring, so a
            // client that reads one of those frames finds its descriptor already there.
            if (!batch.fds.empty()) {
                if (const auto sent = co_await send_descriptors(batch.fds); !sent) {
                    close(sent.error().message);
                    co_return;
                }
            }
            if (const auto written = co_await rings_->write(batch.buffers); !written) {
                if (rings_->peer_lied())
                    on_protocol_error();  // no error frame: the ring it would go into is the broken one
                close(written.error().message);
                co_return;
            }
            continue;
        }
        const bool then_rings = batch.then_rings;
        if (!batch.fds.empty()) {
            // Region descriptors ride on the batch's first bytes; the rest follows as usual.
            const auto sent = co_await send_with_fds(batch);
            if (!sent) {
                close(sent.error().message);
                co_return;
            }
            consume(batch.buffers, *sent);
        }
        if (!batch.buffers.empty()) {
            auto [ec, n] = co_await stream_.write(batch.buffers);
            if (ec) {
                close(ec.message());
                co_return;
            }
        }
        if (then_rings)
            writing_rings_ = true;
    }
}

}  // namespace plexus::daemon
