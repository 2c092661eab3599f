#pragma once
// Threading: made once, then read-only; shared by every connection of a daemon or name server, on
// any thread (of() takes a lock).

#include <memory>

#include "plexus/proto/auth.hpp"

struct ssl_ctx_st;

namespace plexus::daemon {

/// The TLS context of a deployment's links (proto/tls_psk.hpp): TLS 1.3 keyed by the secret, or
/// mutual TLS with this node's certificate when it has an identity (proto/identity.hpp).
class TlsContext {
public:
    /// The context of `secret`, made at its first use and shared while any connection holds it:
    /// OpenSSL 3 takes a while to make one (its providers' suites are looked up), and every link of
    /// a process uses the same secret.
    static std::shared_ptr<TlsContext> of(const proto::Secret& secret);

    explicit TlsContext(const proto::Secret& secret);
    ~TlsContext();
    TlsContext(const TlsContext&) = delete;
    TlsContext& operator=(const TlsContext&) = delete;

    /// The OpenSSL context (SSL_CTX*) sessions are made from (ByteStream).
    ssl_ctx_st* native() const { return context_; }

private:
    ssl_ctx_st* context_;
};

}  // namespace plexus::daemon
