#pragma once
// Threading: made once, then read-only; shared by every connection of a daemon or name server, on
// any thread (of() takes a lock).

#include <memory>

#include "plexus/proto/auth.hpp"

namespace boost::asio::ssl {
class context;
}

namespace plexus::daemon {

/// The TLS context of a deployment's links (proto/tls_psk.hpp): TLS 1.3 keyed by the secret.
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

    boost::asio::ssl::context& asio_context() { return *context_; }

private:
    std::unique_ptr<boost::asio::ssl::context> context_;
};

}  // namespace plexus::daemon
