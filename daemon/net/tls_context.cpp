#include "tls_context.hpp"

#include <openssl/ssl.h>

#include <map>
#include <mutex>

#include "plexus/proto/tls_psk.hpp"

namespace plexus::daemon {

TlsContext::TlsContext(const proto::Secret& secret) : context_(proto::new_psk_tls_context(secret)) {}

TlsContext::~TlsContext() {
    ::SSL_CTX_free(context_);
}

std::shared_ptr<TlsContext> TlsContext::of(const proto::Secret& secret) {
    static std::mutex lock;
    static std::map<proto::Digest, std::weak_ptr<TlsContext>>
        made;  // by key: a secret's own bytes stay in Secret
    const std::lock_guard guard(lock);
    auto& entry = made[secret.tls_key()];
    if (auto context = entry.lock())
        return context;
    auto context = std::make_shared<TlsContext>(secret);
    entry = context;
    return context;
}

}  // namespace plexus::daemon
