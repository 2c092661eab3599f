#include "byte_stream.hpp"

#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/ssl.h>

#include <boost/asio/ssl/error.hpp>
#include <stdexcept>

#include "plexus/proto/tls_psk.hpp"
#include "signal.hpp"
#include "tls_context.hpp"

namespace plexus::daemon {

namespace {
// Small frames are gathered into one TLS record's worth before they are encrypted: a record per
// frame would cost 22 bytes each and, once written, a system call each.
constexpr std::size_t record_bytes = 16 * 1024;
// A large piece is encrypted and written this much at a time: few system calls, and the buffers a
// connection keeps after a burst stay this small.
constexpr std::size_t write_slice = 128 * 1024;
// What one read from the socket takes: two records at once, or many small ones. Each encrypted
// link keeps this much (allocated at its first read).
constexpr std::size_t read_bytes = 32 * 1024;

using Result = std::tuple<boost::system::error_code, std::size_t>;

/// OpenSSL's error, as Asio's TLS errors are made: is_tls_error() knows it, message() gives
/// OpenSSL's reason ("decryption failed or bad record mac").
boost::system::error_code tls_error() {
    const unsigned long code = ::ERR_get_error();
    ::ERR_clear_error();
    return {static_cast<int>(code != 0 ? code : SSL_R_UNEXPECTED_RECORD), asio::error::get_ssl_category()};
}
}  // namespace

/// The TLS session, driven by hand over two memory BIOs: OpenSSL never touches the socket. What
/// the socket brings goes into `in`, what OpenSSL writes comes out of `out`, and this class moves
/// the bytes in large reads and writes (Asio's ssl::stream moved one 16 KiB record per pass: a
/// 1 MiB message took 64 of them).
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
    }
    ~Tls() { ::SSL_free(ssl); }
    Tls(const Tls&) = delete;
    Tls& operator=(const Tls&) = delete;

    SSL* ssl = nullptr;
    BIO* in = nullptr;
    BIO* out = nullptr;
    proto::Bytes gathered;  ///< small pieces waiting to be encrypted as one record
    proto::Bytes sending;   ///< `out`'s bytes on their way to the socket
    proto::Bytes received;  ///< the socket's bytes, before `in` takes them
    bool flushing = false;  ///< a coroutine is writing `out` to the socket
    Signal flushed;         ///< notified when it is done
    /// The session's error (or the peer's close_notify) that came after plain bytes the last read
    /// returned: the next read returns it. OpenSSL keeps the session failed but not its reason.
    boost::system::error_code failed;

    /// Encrypts all of `bytes` into `out`. False on an error of OpenSSL's.
    bool encrypt(proto::ByteView bytes) {
        while (!bytes.empty()) {
            const int n =
                ::SSL_write(ssl, bytes.data(), static_cast<int>(std::min(bytes.size(), write_slice)));
            if (n <= 0)
                return false;
            bytes = bytes.subspan(static_cast<std::size_t>(n));
        }
        return true;
    }
};

ByteStream::ByteStream(Socket socket) : socket_(std::move(socket)) {}

ByteStream::~ByteStream() = default;

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
    tls.received.resize(read_bytes);
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
        // Whatever the handshake wrote goes out, an alert that says why it failed too.
        if (auto error = co_await flush_tls(true); error && failure.empty())
            failure = error.message();
        if (!failure.empty()) {
            tls_.reset();
            co_return proto::Error{"TLS handshake failed: " + failure};
        }
        if (done == 1) {
            peer_subject_ = proto::peer_subject(tls.ssl);
            co_return proto::Ok{};
        }
        auto [error, n] = co_await socket_.async_read_some(asio::buffer(tls.received), use_nothrow);
        if (error) {
            tls_.reset();
            co_return proto::Error{"TLS handshake failed: " +
                                   (error == asio::error::eof ? std::string("the peer closed the connection")
                                                              : error.message())};
        }
        ::BIO_write(tls.in, tls.received.data(), static_cast<int>(n));
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
    std::size_t got = 0;
    for (;;) {
        // Every whole record already here, as far as the buffer holds. OpenSSL's calls are not free
        // (a few microseconds each, more with cold caches): when nothing is left in the session or
        // in `in`, the read that would only say "want more" is not made. The error queue is empty
        // here: every failure below takes its errors off it.
        while (got < buffer.size()) {
            if (got > 0 && ::SSL_pending(tls.ssl) == 0 && BIO_pending(tls.in) == 0)
                break;
            const int n = ::SSL_read(tls.ssl, into + got,
                                     static_cast<int>(std::min<std::size_t>(buffer.size() - got, INT32_MAX)));
            if (n > 0) {
                got += static_cast<std::size_t>(n);
                continue;
            }
            const int reason = ::SSL_get_error(tls.ssl, n);
            if (reason == SSL_ERROR_WANT_READ)
                break;
            if (reason == SSL_ERROR_ZERO_RETURN) {  // the peer's close_notify
                ::ERR_clear_error();
                tls.failed = asio::error::eof;
            } else {
                tls.failed = tls_error();
            }
            // The plain bytes before it first; the next read returns the error.
            co_return std::tuple{got > 0 ? boost::system::error_code{} : tls.failed, got};
        }
        if (BIO_pending(tls.out) > 0)
            co_await flush_tls(false);  // what reading made OpenSSL say (an alert): no one else would send it
        if (got > 0)
            co_return std::tuple{boost::system::error_code{}, got};
        // A session the peer ended without its close_notify reads as an end of stream (see the
        // header): the socket's own end of file.
        auto [error, n] = co_await socket_.async_read_some(asio::buffer(tls.received), use_nothrow);
        if (error)
            co_return std::tuple{error, std::size_t{0}};
        ::BIO_write(tls.in, tls.received.data(), static_cast<int>(n));
    }
}

Task<Result> ByteStream::write_tls(const std::vector<asio::const_buffer>& buffers) {
    auto& tls = *tls_;
    std::size_t written = 0;
    // `buffers` is the writer's batch, which nothing else touches while the writer waits here (it
    // is the writer's own local, and the writer is suspended in this call).
    auto encrypt = [&](proto::ByteView bytes) -> Task<boost::system::error_code> {
        for (std::size_t at = 0; at < bytes.size(); at += write_slice) {
            const auto slice = bytes.subspan(at, std::min(write_slice, bytes.size() - at));
            if (!tls.encrypt(slice))
                co_return tls_error();
            if (auto error = co_await flush_tls(true))
                co_return error;
            written += slice.size();
        }
        co_return boost::system::error_code{};
    };
    for (const auto& piece : buffers) {
        const proto::ByteView bytes(static_cast<const std::uint8_t*>(piece.data()), piece.size());
        if (bytes.size() < record_bytes) {
            tls.gathered.insert(tls.gathered.end(), bytes.begin(), bytes.end());
            if (tls.gathered.size() < record_bytes)
                continue;
        }
        if (!tls.gathered.empty()) {
            auto error = co_await encrypt(tls.gathered);
            tls.gathered.clear();
            if (error)
                co_return std::tuple{error, written};
        }
        if (bytes.size() >= record_bytes) {
            if (auto error = co_await encrypt(bytes))
                co_return std::tuple{error, written};
        }
    }
    boost::system::error_code error;
    if (!tls.gathered.empty()) {
        error = co_await encrypt(tls.gathered);
        tls.gathered.clear();
    }
    co_return std::tuple{error, written};
}

Task<boost::system::error_code> ByteStream::flush_tls(bool wait) {
    auto& tls = *tls_;
    if (tls.flushing && !wait)
        co_return boost::system::error_code{};  // the one flushing sends these bytes too: it loops until
                                                // `out` is empty
    while (tls.flushing)
        co_await tls.flushed.wait();
    tls.flushing = true;
    boost::system::error_code error;
    while (!error && BIO_pending(tls.out) > 0) {
        tls.sending.resize(static_cast<std::size_t>(BIO_pending(tls.out)));
        ::BIO_read(tls.out, tls.sending.data(), static_cast<int>(tls.sending.size()));
        auto [write_error, n] = co_await asio::async_write(socket_, asio::buffer(tls.sending), use_nothrow);
        error = write_error;
    }
    if (tls.sending.capacity() > 2 * write_slice)
        proto::Bytes().swap(tls.sending);  // a burst's buffer goes back: a link keeps little when idle
    tls.flushing = false;
    tls.flushed.notify();
    co_return error;
}

}  // namespace plexus::daemon
