#pragma once
// TLS 1.3 with an external pre-shared key made from the deployment secret (docs/SECURITY.md,
// "Encrypted links"): every TCP link of a deployment that has a secret is encrypted and
// authenticated end to end, with no certificate to manage. The daemons (OpenSSL over memory BIOs)
// and libplexus (OpenSSL directly, blocking) use the same context, so both ends agree on every
// parameter by construction.
//
// The key is HMAC-SHA256(secret, "plexus tls psk v1"): the secret itself never reaches TLS. Only
// TLS 1.3, only TLS_AES_128_GCM_SHA256 and TLS_CHACHA20_POLY1305_SHA256 (the first where the CPU
// has AES instructions), only the psk_dhe_ke mode (an ephemeral X25519 exchange on top of the key:
// a secret stolen later does not open recorded traffic), no session tickets.

#include <cstdint>
#include <string>

#include "plexus/proto/auth.hpp"

struct ssl_ctx_st;
struct ssl_st;

namespace plexus::proto {

/// A new OpenSSL context (SSL_CTX*, the caller owns it: SSL_CTX_free) for either end of a link
/// protected by `secret`. Throws std::runtime_error when OpenSSL cannot make one (out of memory).
ssl_ctx_st* new_psk_tls_context(const Secret& secret);

/// A new OpenSSL context with what every link's TLS has in common, keyed by a secret or by
/// certificates (identity.hpp): TLS 1.3 only, its two suites, no resumption, writes that hand the
/// socket what fits. Throws std::runtime_error when OpenSSL cannot make one.
ssl_ctx_st* new_tls13_context();

/// A new context for a link of a process with `secret`: mutual TLS with certificates when the
/// secret comes with an identity (Secret::identity()), else TLS keyed by the secret.
ssl_ctx_st* new_link_tls_context(const Secret& secret);
/// Tells the contexts new_link_tls_context() makes apart: two secrets with the same key and no
/// identity share one; an identity's changes with its revocation list (a context made before the
/// list changed must not be used for a new link).
std::string link_tls_context_key(const Secret& secret);

/// The reason of the last OpenSSL error on this thread (and clears the queue): for messages.
std::string last_tls_error();
/// The reason a handshake of `session` failed: last_tls_error(), and why the peer's certificate
/// was refused when it was ("certificate revoked", "certificate has expired").
std::string tls_handshake_failure(ssl_st* session);

/// True when a stream's first two bytes are a TLS handshake record's (content type 22, version
/// major 3): a ClientHello. A Plexus stream starts with a hello frame (a varint length, then type
/// 1), so its second byte is never 3: a listener tells an encrypting peer from a plain one by two
/// bytes, and can still tell a plain one why it is refused.
inline bool starts_tls(std::uint8_t first, std::uint8_t second) {
    return first == 0x16 && second == 0x03;
}

}  // namespace plexus::proto
