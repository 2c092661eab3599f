#include "tls_context.hpp"

#include <openssl/ssl.h>

#include <map>
#include <mutex>

#include "plexus/proto/tls_psk.hpp"
#include "tls_records.hpp"

namespace plexus::daemon {

TlsContext::TlsContext(const proto::Secret& secret) : context_(proto::new_link_tls_context(secret)) {
    // Links protect their records themselves after the handshake (tls_records.hpp): they need the
    // traffic secrets.
    capture_traffic_secrets(context_);
}

TlsContext::~TlsContext() {
    ::SSL_CTX_free(context_);
}

std::shared_ptr<TlsContext> TlsContext::of(const proto::Secret& secret) {
    static std::mutex lock;
    // By key: a secret's own bytes stay in Secret. An identity's revocation list changes the key,
    // so links made after it changed check certificates against the new list.
    static std::map<std::string, std::weak_ptr<TlsContext>> made;
    const std::lock_guard guard(lock);
    std::erase_if(made, [](const auto& entry) { return entry.second.expired(); });
    auto& entry = made[proto::link_tls_context_key(secret)];
    if (auto context = entry.lock())
        return context;
    auto context = std::make_shared<TlsContext>(secret);
    entry = context;
    return context;
}

}  // namespace plexus::daemon
