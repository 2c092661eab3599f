#include "plexus/proto/tls_psk.hpp"

#include <openssl/err.h>
#include <openssl/ssl.h>

#include <cstring>
#include <memory>
#include <stdexcept>

#include "plexus/proto/hex.hpp"
#include "plexus/proto/identity.hpp"

namespace plexus::proto {

namespace {

// Names the key in the ClientHello (in clear: it says "a Plexus deployment key", nothing more).
constexpr std::string_view psk_identity = "plexus deployment secret v1";
// TLS_AES_128_GCM_SHA256: the suite the key is made for (a TLS 1.3 external key is bound to one
// hash, SHA-256 here); TLS_CHACHA20_POLY1305_SHA256 shares the hash and is faster without AES-NI.
constexpr unsigned char aes_128_gcm_sha256[] = {0x13, 0x01};

/// The session every connection of a context offers (client) or accepts (server), kept in the
/// context's ex_data and freed with it.
int session_index() {
    static const int index = ::SSL_CTX_get_ex_new_index(
        0, nullptr, nullptr, nullptr, [](void*, void* session, CRYPTO_EX_DATA*, int, long, void*) {
            ::SSL_SESSION_free(static_cast<SSL_SESSION*>(session));
        });
    return index;
}

SSL_SESSION* session_of(SSL* ssl) {
    return static_cast<SSL_SESSION*>(::SSL_CTX_get_ex_data(::SSL_get_SSL_CTX(ssl), session_index()));
}

int use_session(SSL* ssl, const EVP_MD* md, const unsigned char** id, std::size_t* id_size,
                SSL_SESSION** offered) {
    SSL_SESSION* session = session_of(ssl);
    // After a HelloRetryRequest the server names the hash; a key for another one is not offered.
    if (md != nullptr && md != ::SSL_CIPHER_get_handshake_digest(::SSL_SESSION_get0_cipher(session))) {
        *offered = nullptr;
        return 1;
    }
    ::SSL_SESSION_up_ref(session);
    *offered = session;
    *id = reinterpret_cast<const unsigned char*>(psk_identity.data());
    *id_size = psk_identity.size();
    return 1;
}

int find_session(SSL* ssl, const unsigned char* id, std::size_t id_size, SSL_SESSION** found) {
    *found = nullptr;  // an unknown identity: no key, and the handshake fails
    if (id_size != psk_identity.size() || std::memcmp(id, psk_identity.data(), id_size) != 0)
        return 1;
    SSL_SESSION* session = session_of(ssl);
    ::SSL_SESSION_up_ref(session);
    *found = session;
    return 1;
}

[[noreturn]] void fail(const char* what) {
    throw std::runtime_error(std::string("cannot make the TLS context: ") + what + ": " + last_tls_error());
}

}  // namespace

std::string last_tls_error() {
    std::string reasons;
    while (const unsigned long code = ::ERR_get_error()) {
        char text[256];
        ::ERR_error_string_n(code, text, sizeof text);
        const char* reason = ::ERR_reason_error_string(code);
        if (!reasons.empty())
            reasons += "; ";
        reasons += reason ? reason : text;
    }
    return reasons.empty() ? "no reason given" : reasons;
}

ssl_ctx_st* new_tls13_context() {
    std::unique_ptr<SSL_CTX, decltype(&::SSL_CTX_free)> context(::SSL_CTX_new(::TLS_method()),
                                                                ::SSL_CTX_free);
    if (!context)
        fail("SSL_CTX_new");
    SSL_CTX* ctx = context.get();
    ::SSL_CTX_set_min_proto_version(ctx, TLS1_3_VERSION);
    ::SSL_CTX_set_max_proto_version(ctx, TLS1_3_VERSION);
    if (::SSL_CTX_set_ciphersuites(ctx, "TLS_AES_128_GCM_SHA256:TLS_CHACHA20_POLY1305_SHA256") != 1)
        fail("no TLS 1.3 suites");
    // No resumption: every connection proves the key afresh, and no ticket outlives a secret change.
    ::SSL_CTX_set_options(ctx, SSL_OP_NO_TICKET);
    // A peer that closes without a close_notify ends the stream as a close would: frames delimit
    // themselves, so the reader tells a cut inside a frame from a close between two.
    ::SSL_CTX_set_options(ctx, SSL_OP_IGNORE_UNEXPECTED_EOF);
    ::SSL_CTX_set_num_tickets(ctx, 0);
    ::SSL_CTX_set_session_cache_mode(ctx, SSL_SESS_CACHE_OFF);
    // Writes hand the socket what fits, like a plain socket: the writer keeps the rest.
    ::SSL_CTX_set_mode(ctx, SSL_MODE_ENABLE_PARTIAL_WRITE | SSL_MODE_ACCEPT_MOVING_WRITE_BUFFER);
    return context.release();
}

ssl_ctx_st* new_psk_tls_context(const Secret& secret) {
    std::unique_ptr<SSL_CTX, decltype(&::SSL_CTX_free)> context(new_tls13_context(), ::SSL_CTX_free);
    SSL_CTX* ctx = context.get();

    std::unique_ptr<SSL, decltype(&::SSL_free)> probe(::SSL_new(ctx), ::SSL_free);
    const SSL_CIPHER* cipher = probe ? ::SSL_CIPHER_find(probe.get(), aes_128_gcm_sha256) : nullptr;
    if (!cipher)
        fail("no TLS_AES_128_GCM_SHA256");
    std::unique_ptr<SSL_SESSION, decltype(&::SSL_SESSION_free)> session(::SSL_SESSION_new(),
                                                                        ::SSL_SESSION_free);
    const Digest key = secret.tls_key();
    if (!session || ::SSL_SESSION_set1_master_key(session.get(), key.data(), key.size()) != 1 ||
        ::SSL_SESSION_set_cipher(session.get(), cipher) != 1 ||
        ::SSL_SESSION_set_protocol_version(session.get(), TLS1_3_VERSION) != 1)
        fail("the pre-shared key");
    if (::SSL_CTX_set_ex_data(ctx, session_index(), session.get()) != 1)
        fail("SSL_CTX_set_ex_data");
    session.release();  // the context frees it now
    ::SSL_CTX_set_psk_use_session_callback(ctx, use_session);
    ::SSL_CTX_set_psk_find_session_callback(ctx, find_session);
    return context.release();
}

std::string tls_handshake_failure(ssl_st* session) {
    std::string reason = last_tls_error();
    // Only when this end checks certificates: one keyed by the secret records a peer's it never
    // asked for as unverified.
    const long verified = ::SSL_get_verify_result(session);
    if ((::SSL_get_verify_mode(session) & SSL_VERIFY_PEER) != 0 && verified != X509_V_OK)
        reason += std::string(" (the peer's certificate: ") + ::X509_verify_cert_error_string(verified) + ")";
    return reason;
}

ssl_ctx_st* new_link_tls_context(const Secret& secret) {
    if (const Identity* identity = secret.identity())
        return new_certificate_tls_context(*identity);
    return new_psk_tls_context(secret);
}

std::string link_tls_context_key(const Secret& secret) {
    const Digest key = secret.tls_key();
    std::string text = hex_text(ByteView(key.data(), key.size()));
    if (const Identity* identity = secret.identity()) {
        text += " " + identity->directory() + " " + std::to_string(identity->crl_changed());
    }
    return text;
}

}  // namespace plexus::proto
