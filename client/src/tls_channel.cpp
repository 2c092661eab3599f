#include "tls_channel.hpp"

#include <fcntl.h>
#include <poll.h>

#include <openssl/ssl.h>

#include <cerrno>
#include <cstring>
#include <map>
#include <memory>

#include "plexus/client.hpp"
#include "plexus/proto/tls_psk.hpp"

namespace plexus::detail {

namespace {

// Small pieces are gathered into one record: a record per frame would cost a system call each.
constexpr std::size_t record_bytes = 16 * 1024;

/// The context of a secret, made once per process: OpenSSL 3 takes a while to make one. Freed
/// at exit (its channels, each holding a reference of its own, are gone by then or keep it alive).
SSL_CTX* context_of(const proto::Secret& secret) {
    // OpenSSL is set up before the map below exists: functions registered to run at exit run in
    // the reverse order, so the map then frees its contexts before OpenSSL's own clean-up runs.
    // The other way round, the clean-up drops the callback that frees each context's session,
    // and every process that spoke TLS leaked it (LeakSanitizer; found when Secret stopped
    // calling OpenSSL, which had set it up earlier by chance).
    ::OPENSSL_init_ssl(0, nullptr);
    using Owned = std::unique_ptr<SSL_CTX, decltype(&::SSL_CTX_free)>;
    static std::mutex lock;
    static std::map<std::string, Owned> made;
    const std::lock_guard guard(lock);
    const std::string key = proto::link_tls_context_key(secret);
    auto found = made.find(key);
    if (found == made.end())
        found = made.emplace(key, Owned(proto::new_link_tls_context(secret), ::SSL_CTX_free)).first;
    return found->second.get();
}

/// Waits for `events` on `fd` until `deadline`; false when it passed.
bool wait_for(int fd, short events, std::chrono::steady_clock::time_point deadline) {
    for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0)
            return false;
        pollfd ready{fd, events, 0};
        const int n = ::poll(&ready, 1, static_cast<int>(left.count()));
        if (n > 0)
            return true;
        if (n < 0 && errno != EINTR)
            return true;  // the next call shows the error
    }
}

}  // namespace

TlsChannel::TlsChannel(int fd, const proto::Secret& secret, const std::string& address,
                       std::chrono::steady_clock::time_point deadline)
    : fd_(fd) {
    ssl_ = ::SSL_new(context_of(secret));
    if (!ssl_ || ::SSL_set_fd(ssl_, fd) != 1) {
        ::SSL_free(ssl_);
        throw Error(ErrorCode::refused, "cannot start TLS with " + address + ": " + proto::last_tls_error());
    }
    ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
    for (;;) {
        short waits_for = 0;
        const ssize_t done = outcome(::SSL_connect(ssl_), &waits_for);
        if (done > 0)
            return;
        if (done < 0 && errno == EAGAIN && wait_for(fd_, waits_for, deadline))
            continue;
        const std::string why = done < 0 && errno == EAGAIN ? "no answer in time" : failure_;
        ::SSL_free(ssl_);
        if (done < 0 && errno == EAGAIN)
            throw Error(ErrorCode::timeout, "TLS handshake with " + address + ": " + why);
        throw Error(ErrorCode::refused,
                    "TLS handshake with " + address + " failed: " + why +
                        (secret.identity()
                             ? " (with PLEXUS_IDENTITY, it must show a valid certificate of the same CA, and "
                               "accept this identity's)"
                             : " (it does not hold this deployment's secret, or runs without one: "
                               "PLEXUS_SECRET_FILE must name the same secret as its --secret-file)"));
    }
}

TlsChannel::~TlsChannel() {
    ::SSL_free(ssl_);  // no close_notify: frames delimit themselves, and the socket closes next
}

ssize_t TlsChannel::outcome(int result, short* waits_for) {
    if (result > 0)
        return result;
    switch (::SSL_get_error(ssl_, result)) {
        case SSL_ERROR_WANT_READ:
            if (waits_for)
                *waits_for = POLLIN;
            errno = EAGAIN;
            return -1;
        case SSL_ERROR_WANT_WRITE:
            if (waits_for)
                *waits_for = POLLOUT;
            errno = EAGAIN;
            return -1;
        case SSL_ERROR_ZERO_RETURN:
            return 0;  // the peer's close_notify, or its close (SSL_OP_IGNORE_UNEXPECTED_EOF)
        case SSL_ERROR_SYSCALL:
            failure_ = errno != 0 ? std::strerror(errno) : "the connection broke";
            errno = EPROTO;
            return -1;
        default:
            failure_ = proto::tls_handshake_failure(ssl_);
            errno = EPROTO;
            return -1;
    }
}

ssize_t TlsChannel::receive(std::uint8_t* at, std::size_t room) {
    const std::lock_guard guard(mutex_);
    std::size_t n = 0;
    const int result = ::SSL_read_ex(ssl_, at, room, &n);
    return outcome(result == 1 ? static_cast<int>(n) : result);
}

ssize_t TlsChannel::send(const iovec* pieces, std::size_t count) {
    const std::lock_guard guard(mutex_);
    if (count == 0)
        return 0;
    const void* from = pieces[0].iov_base;
    std::size_t size = pieces[0].iov_len;
    if (size < record_bytes && count > 1) {
        // The same first bytes every time: a write that found no room must be offered again.
        gathered_.clear();
        for (std::size_t i = 0; i < count && gathered_.size() < record_bytes; ++i) {
            const auto* bytes = static_cast<const std::uint8_t*>(pieces[i].iov_base);
            const std::size_t take = std::min(pieces[i].iov_len, record_bytes - gathered_.size());
            gathered_.insert(gathered_.end(), bytes, bytes + take);
        }
        from = gathered_.data();
        size = gathered_.size();
    }
    std::size_t n = 0;
    const int result = ::SSL_write_ex(ssl_, from, size, &n);
    return outcome(result == 1 ? static_cast<int>(n) : result);
}

void TlsChannel::send_all(const std::uint8_t* bytes, std::size_t size,
                          std::chrono::steady_clock::time_point deadline) {
    std::size_t sent = 0;
    while (sent < size) {
        const iovec piece{const_cast<std::uint8_t*>(bytes + sent), size - sent};
        const ssize_t n = send(&piece, 1);
        if (n > 0) {
            sent += static_cast<std::size_t>(n);
            continue;
        }
        if (n < 0 && errno == EAGAIN && wait_for(fd_, POLLOUT, deadline))
            continue;
        throw Error(ErrorCode::refused,
                    "sending over TLS: " + (n < 0 && errno == EAGAIN ? "no room in time" : failure()));
    }
}

ssize_t TlsChannel::receive_by(std::uint8_t* at, std::size_t room,
                               std::chrono::steady_clock::time_point deadline) {
    for (;;) {
        const ssize_t n = receive(at, room);
        if (n >= 0 || errno != EAGAIN)
            return n;
        if (!wait_for(fd_, POLLIN, deadline)) {
            errno = EAGAIN;  // nothing in time
            return -1;
        }
    }
}

std::string TlsChannel::failure() const {
    const std::lock_guard guard(mutex_);
    return failure_;
}

std::optional<proto::Subject> TlsChannel::peer_subject() const {
    const std::lock_guard guard(mutex_);
    return proto::peer_subject(ssl_);
}

}  // namespace plexus::detail
