#include "byte_stream.hpp"

#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/ssl.h>

#include <boost/asio/ssl/error.hpp>
#include <cstring>
#include <stdexcept>

#include "plexus/proto/tls_psk.hpp"
#include "signal.hpp"
#include "tls_context.hpp"
#include "tls_records.hpp"

namespace plexus::daemon {

namespace {
// A write is sealed and handed to the socket this much at a time: few system calls, and the
// buffers a connection keeps after a burst stay this small.
constexpr std::size_t write_slice = 128 * 1024;
// What one read from the socket takes: two records at once, or many small ones. Each encrypted
// link keeps this much (allocated at its first read).
constexpr std::size_t read_bytes = 32 * 1024;
// While the reader wants a large frame's rest, the socket is read this much at a time (fewer
// system calls); the buffer goes back to read_bytes when the burst is over.
constexpr std::size_t large_read_bytes = 256 * 1024;
constexpr std::size_t large_room = 128 * 1024;
// A write buffer larger than this (a large message's slices) is freed once it is sent; smaller
// ones (small frames) are kept for the next write.
constexpr std::size_t kept_write_bytes = 64 * 1024;

using Result = std::tuple<boost::system::error_code, std::size_t>;

}  // namespace

/// The TLS session. OpenSSL runs the handshake over two memory BIOs (it never touches the socket);
/// after it, TlsRecords protects the records itself (tls_records.hpp says why) and the OpenSSL
/// session is freed.
struct ByteStream::Tls {
    Tls(TlsContext& context, const asio::any_io_executor& executor)
        : ssl(::SSL_new(context.native())), flushed(executor) {
        if (!ssl)
            throw std::runtime_error("OpenSSL could not make a TLS session: " + proto::last_tls_error());
        in = ::BIO_new(::BIO_s_mem());
        out = ::BIO_new(::BIO_s_mem());
        // An empty `in` means "wait for the socket", not "the peer closed".
        BIO_set_mem_eof_return(in, -1);
        BIO_set_mem_eof_return(out, -1);
        ::SSL_set_bio(ssl, in, out);  // the session owns them now
        attach_traffic_secrets(ssl, &secrets);
    }
    ~Tls() { ::SSL_free(ssl); }
    Tls(const Tls&) = delete;
    Tls& operator=(const Tls&) = delete;

    /// What the handshake wrote, queued for the socket.
    void take_handshake_output() {
        while (BIO_pending(out) > 0) {
            const int n = BIO_pending(out);
            ::BIO_read(out, outgoing.append(static_cast<std::size_t>(n)), n);
        }
    }

    /// Moves from OpenSSL's records to ours; false when the session cannot (a suite TlsRecords does
    /// not know, or OpenSSL read past its handshake: neither happens with this context).
    bool end_handshake() {
        records = TlsRecords::after_handshake(ssl, secrets);
        secrets.forget();
        if (!records || ::SSL_has_pending(ssl) == 1)
            return false;
        // What the peer sent right after its last handshake message: its first records.
        const int left = BIO_pending(in);
        if (left > 0) {
            if (received_size < static_cast<std::size_t>(left))
                size_received(static_cast<std::size_t>(left), 0);
            ::BIO_read(in, received.get(), left);
            received_end = static_cast<std::size_t>(left);
        }
        ::SSL_free(ssl);
        ssl = nullptr;
        return true;
    }

    /// Makes `received` `size` bytes long, keeping its first `keep` (not zeroed first: the socket
    /// writes them).
    void size_received(std::size_t size, std::size_t keep) {
        auto fresh = std::make_unique_for_overwrite<std::uint8_t[]>(size);
        if (keep > 0)
            std::memcpy(fresh.get(), received.get(), keep);
        received = std::move(fresh);
        received_size = size;
    }

    SSL* ssl = nullptr;  ///< during the handshake only
    BIO* in = nullptr;
    BIO* out = nullptr;
    TrafficSecrets secrets;
    std::unique_ptr<TlsRecords> records;  ///< after the handshake
    std::vector<proto::ByteView> batch;   ///< the writer's pieces for one seal
    RecordBuffer outgoing;                ///< sealed, not yet handed to the socket
    RecordBuffer sending;                 ///< on their way to the socket
    /// The socket's bytes: [received_begin, received_end) are records not yet opened (the last
    /// maybe not all here); [plain_begin, plain_end), before them, are bytes of a record opened in
    /// place that the last read had no room for.
    std::unique_ptr<std::uint8_t[]> received;
    std::size_t received_size = 0;
    std::size_t received_begin = 0;
    std::size_t received_end = 0;
    std::size_t plain_begin = 0;
    std::size_t plain_end = 0;
    bool flushing = false;  ///< a coroutine is writing to the socket
    Signal flushed;         ///< notified when it is done
    /// The error (or the peer's close_notify) that came after plain bytes the last read returned:
    /// the next read returns it.
    boost::system::error_code failed;
};

ByteStream::ByteStream(Socket socket) : socket_(std::move(socket)) {}

ByteStream::~ByteStream() = default;

void ByteStream::CertificateFree::operator()(x509_st* certificate) const {
    ::X509_free(certificate);
}

bool ByteStream::is_tls_error(const boost::system::error_code& error) {
    return error.category() == asio::error::get_ssl_category();
}

bool ByteStream::is_peer_alert(const boost::system::error_code& error) {
    // OpenSSL gives a received alert the reason SSL_AD_REASON_OFFSET + its number.
    return is_tls_error(error) &&
           ERR_GET_REASON(static_cast<unsigned long>(static_cast<unsigned int>(error.value()))) >=
               SSL_AD_REASON_OFFSET;
}

Task<proto::Status> ByteStream::start_tls(TlsContext& context, bool accepting, proto::ByteView first) {
    tls_ = std::make_unique<Tls>(context, socket_.get_executor());
    auto& tls = *tls_;
    tls.size_received(read_bytes, 0);
    if (accepting)
        ::SSL_set_accept_state(tls.ssl);
    else
        ::SSL_set_connect_state(tls.ssl);
    if (!first.empty())
        ::BIO_write(tls.in, first.data(), static_cast<int>(first.size()));
    ::ERR_clear_error();
    for (;;) {
        const int done = ::SSL_do_handshake(tls.ssl);
        const int reason = done == 1 ? SSL_ERROR_NONE : ::SSL_get_error(tls.ssl, done);
        std::string failure;
        if (reason != SSL_ERROR_NONE && reason != SSL_ERROR_WANT_READ)
            failure = proto::tls_handshake_failure(tls.ssl);
        tls.take_handshake_output();
        // Whatever the handshake wrote goes out, an alert that says why it failed too.
        if (auto error = co_await flush_tls(true); error && failure.empty())
            failure = error.message();
        if (!failure.empty()) {
            tls_.reset();
            co_return proto::Error{"TLS handshake failed: " + failure};
        }
        if (done == 1) {
            peer_subject_ = proto::peer_subject(tls.ssl);
            if (peer_subject_)
                peer_certificate_.reset(::SSL_get1_peer_certificate(tls.ssl));
            if (!tls.end_handshake()) {
                tls_.reset();
                co_return proto::Error{
                    "TLS handshake failed: its session cannot move to Plexus's record layer"};
            }
            co_return proto::Ok{};
        }
        auto [error, n] = co_await socket_.async_read_some(
            asio::buffer(tls.received.get(), tls.received_size), use_nothrow);
        if (error) {
            tls_.reset();
            co_return proto::Error{"TLS handshake failed: " +
                                   (error == asio::error::eof ? std::string("the peer closed the connection")
                                                              : error.message())};
        }
        ::BIO_write(tls.in, tls.received.get(), static_cast<int>(n));
    }
}

// The plain paths return the socket's own operation: no coroutine frame of ours on the data path.
Task<Result> ByteStream::read_some(asio::mutable_buffer buffer) {
    if (tls_)
        return read_tls(buffer);
    if (!given_back_.empty())
        return read_given_back(buffer);
    return socket_.async_read_some(buffer, use_nothrow);
}

Task<Result> ByteStream::read_given_back(asio::mutable_buffer buffer) {
    const std::size_t n = asio::buffer_copy(buffer, asio::buffer(given_back_));
    given_back_.erase(given_back_.begin(), given_back_.begin() + static_cast<std::ptrdiff_t>(n));
    co_return std::tuple{boost::system::error_code{}, n};
}

Task<Result> ByteStream::write(const std::vector<asio::const_buffer>& buffers) {
    return tls_ ? write_tls(buffers) : asio::async_write(socket_, buffers, use_nothrow);
}

Task<Result> ByteStream::read_tls(asio::mutable_buffer buffer) {
    auto& tls = *tls_;
    if (tls.failed)
        co_return std::tuple{tls.failed, std::size_t{0}};
    auto* into = static_cast<std::uint8_t*>(buffer.data());
    const std::size_t room = buffer.size();
    if (room == 0)
        co_return std::tuple{boost::system::error_code{}, std::size_t{0}};  // as a socket answers
    std::size_t got = 0;
    for (;;) {
        // Every whole record already here, as far as the buffer holds: opened straight into it, or,
        // when its plain bytes might not fit, in place and handed on from there.
        while (got < room) {
            if (tls.plain_begin < tls.plain_end) {
                const std::size_t n = std::min(room - got, tls.plain_end - tls.plain_begin);
                std::memcpy(into + got, tls.received.get() + tls.plain_begin, n);
                tls.plain_begin += n;
                got += n;
                continue;
            }
            const auto framing = TlsRecords::frame(proto::ByteView(tls.received.get() + tls.received_begin,
                                                                   tls.received_end - tls.received_begin));
            if (framing.error)
                co_return co_await fail_tls(framing.error, framing.alert, got);
            if (framing.size == 0)
                break;
            const std::span record(tls.received.get() + tls.received_begin, framing.size);
            const bool fits = framing.size - TlsRecords::header_size - TlsRecords::tag_size <= room - got;
            std::uint8_t* out = fits ? into + got : record.data() + TlsRecords::header_size;
            const auto opened = tls.records->open(record, out);
            tls.received_begin += framing.size;
            if (opened.error)
                co_return co_await fail_tls(opened.error, opened.alert, got);
            if (opened.closed) {
                tls.failed = asio::error::eof;
                co_return std::tuple{got > 0 ? boost::system::error_code{} : tls.failed, got};
            }
            if (fits) {
                got += opened.plain;
            } else {
                tls.plain_begin = static_cast<std::size_t>(out - tls.received.get());
                tls.plain_end = tls.plain_begin + opened.plain;
            }
        }
        if (tls.records->owes_key_update()) {
            tls.records->answer_key_update(tls.outgoing);
            co_await flush_tls(false);  // no one else would send it
        }
        if (got > 0)
            co_return std::tuple{boost::system::error_code{}, got};
        // Nothing opened is left: the partial record, if any, moves to the front.
        const std::size_t partial = tls.received_end - tls.received_begin;
        if (partial > 0 && tls.received_begin > 0)
            std::memmove(tls.received.get(), tls.received.get() + tls.received_begin, partial);
        tls.received_begin = tls.plain_begin = tls.plain_end = 0;
        tls.received_end = partial;
        // The large buffer only while a large frame's bytes wait in the socket: a link that waits
        // for more keeps read_bytes (one that received a burst gives the rest back).
        std::size_t want = read_bytes;
        if (room >= large_room) {
            boost::system::error_code ignored;
            if (socket_.available(ignored) >= read_bytes)
                want = large_read_bytes;
        }
        if (tls.received_size != want)
            tls.size_received(want, partial);
        // A session the peer ended without its close_notify reads as an end of stream (see the
        // header): the socket's own end of file.
        auto [error, n] = co_await socket_.async_read_some(
            asio::buffer(tls.received.get() + partial, tls.received_size - partial), use_nothrow);
        if (error)
            co_return std::tuple{error, std::size_t{0}};
        tls.received_end += n;
    }
}

Task<Result> ByteStream::fail_tls(boost::system::error_code error, std::uint8_t alert, std::size_t got) {
    auto& tls = *tls_;
    tls.failed = error;
    if (alert != 0) {
        // Told to the peer, as OpenSSL would: its log then says why its link ended.
        tls.records->seal_alert(alert, tls.outgoing);
        co_await flush_tls(false);
    }
    // The plain bytes before it first; the next read returns the error.
    co_return std::tuple{got > 0 ? boost::system::error_code{} : error, got};
}

Task<Result> ByteStream::write_tls(const std::vector<asio::const_buffer>& buffers) {
    auto& tls = *tls_;
    if (tls.failed && tls.failed != asio::error::eof)
        co_return std::tuple{tls.failed, std::size_t{0}};  // a broken session seals nothing more
    std::size_t written = 0;
    std::size_t batched = 0;
    // Up to a slice at a time: sealed straight from the frames into `outgoing` (small frames share
    // a record), then written in one system call. `buffers` is the writer's batch, which nothing
    // else touches while the writer waits here (it is the writer's own local, and the writer is
    // suspended in this call).
    auto send_batch = [&]() -> Task<boost::system::error_code> {
        tls.records->seal(tls.batch, tls.outgoing);
        tls.batch.clear();
        auto error = co_await flush_tls(true);
        if (!error)
            written += batched;
        batched = 0;
        co_return error;
    };
    for (const auto& piece : buffers) {
        proto::ByteView bytes(static_cast<const std::uint8_t*>(piece.data()), piece.size());
        while (!bytes.empty()) {
            const std::size_t take = std::min(bytes.size(), write_slice - batched);
            tls.batch.push_back(bytes.first(take));
            batched += take;
            bytes = bytes.subspan(take);
            if (batched == write_slice) {
                if (auto error = co_await send_batch())
                    co_return std::tuple{error, written};
            }
        }
    }
    boost::system::error_code error;
    if (batched > 0)
        error = co_await send_batch();
    co_return std::tuple{error, written};
}

Task<boost::system::error_code> ByteStream::flush_tls(bool wait) {
    auto& tls = *tls_;
    if (tls.flushing && !wait)
        co_return boost::system::error_code{};  // the one flushing sends these bytes too: it loops until
                                                // `outgoing` is empty
    while (tls.flushing)
        co_await tls.flushed.wait();
    tls.flushing = true;
    boost::system::error_code error;
    while (!error && !tls.outgoing.empty()) {
        // Whatever is sealed while these are on their way goes in the next round, in order.
        std::swap(tls.outgoing, tls.sending);
        auto [write_error, n] = co_await asio::async_write(
            socket_, asio::buffer(tls.sending.data(), tls.sending.size()), use_nothrow);
        tls.sending.clear();
        error = write_error;
    }
    // A burst's buffers go back: a link keeps little when idle.
    tls.sending.release_above(kept_write_bytes);
    tls.outgoing.release_above(kept_write_bytes);
    tls.flushing = false;
    tls.flushed.notify();
    co_return error;
}

}  // namespace plexus::daemon
