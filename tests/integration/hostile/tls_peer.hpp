#pragma once
// A TLS handshake on a hostile test's raw stream, keyed by a secret of the test's choosing: a peer
// that guesses the deployment's secret (proto/tls_psk.hpp), done with OpenSSL as a daemon would.

#include <poll.h>
#include <sys/socket.h>

#include <cerrno>

#include <openssl/ssl.h>

#include <chrono>
#include <string>

#include "plexus/proto/tls_psk.hpp"

namespace plexus::test::hostile {

/// Runs the connecting end's TLS handshake on the non-blocking socket `fd` with `secret`'s key;
/// "" when it succeeded, else why it failed (OpenSSL's reason, or "no answer in time").
inline std::string tls_handshake_with(int fd, const proto::Secret& secret,
                                      std::chrono::milliseconds timeout) {
    SSL_CTX* context = proto::new_psk_tls_context(secret);
    SSL* ssl = ::SSL_new(context);
    ::SSL_set_fd(ssl, fd);
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    std::string outcome;
    for (;;) {
        const int result = ::SSL_connect(ssl);
        if (result == 1)
            break;
        const int error = ::SSL_get_error(ssl, result);
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if ((error == SSL_ERROR_WANT_READ || error == SSL_ERROR_WANT_WRITE) && left.count() > 0) {
            pollfd ready{fd, static_cast<short>(error == SSL_ERROR_WANT_READ ? POLLIN : POLLOUT), 0};
            ::poll(&ready, 1, static_cast<int>(left.count()));
            continue;
        }
        outcome = left.count() <= 0 ? "no answer in time" : proto::last_tls_error();
        if (outcome == "no reason given")
            outcome = "the connection closed";
        break;
    }
    ::SSL_free(ssl);
    ::SSL_CTX_free(context);
    return outcome;
}

/// True when the peer closes `fd` within `timeout`, whatever it sends first (a TLS alert).
inline bool closes_within(int fd, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0)
            return false;
        pollfd ready{fd, POLLIN, 0};
        if (::poll(&ready, 1, static_cast<int>(left.count())) <= 0)
            continue;
        char scratch[4096];
        const ssize_t n = ::recv(fd, scratch, sizeof scratch, 0);
        if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR))
            return true;
    }
}

}  // namespace plexus::test::hostile
