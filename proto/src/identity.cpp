#include "plexus/proto/identity.hpp"

#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>
#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <stdexcept>

#include "plexus/proto/pem_files.hpp"
#include "plexus/proto/tls_psk.hpp"

namespace plexus::proto {

namespace {

constexpr std::string_view node_prefix = "plexus:node:";
constexpr std::string_view names_prefix = "plexus:names:";

/// The Plexus subject among a certificate's subjectAltName URIs.
std::optional<Subject> subject_of(X509* certificate) {
    auto* names =
        static_cast<GENERAL_NAMES*>(::X509_get_ext_d2i(certificate, NID_subject_alt_name, nullptr, nullptr));
    if (!names)
        return std::nullopt;
    std::optional<Subject> found;
    for (int i = 0; i < sk_GENERAL_NAME_num(names) && !found; ++i) {
        const GENERAL_NAME* name = sk_GENERAL_NAME_value(names, i);
        if (name->type != GEN_URI)
            continue;
        const auto* text = name->d.uniformResourceIdentifier;
        found = Subject::from_uri(std::string_view(reinterpret_cast<const char*>(ASN1_STRING_get0_data(text)),
                                                   static_cast<std::size_t>(ASN1_STRING_length(text))));
    }
    GENERAL_NAMES_free(names);
    return found;
}

[[noreturn]] void fail(const Identity& identity, const std::string& what) {
    throw std::runtime_error("cannot use the identity in " + identity.directory() + ": " + what + ": " +
                             last_tls_error());
}

}  // namespace

std::string Subject::uri() const {
    return std::string(kind == Kind::node ? node_prefix : names_prefix) + name;
}

std::string Subject::text() const {
    return (kind == Kind::node ? "node '" : "name server '") + name + "'";
}

std::optional<Subject> Subject::from_uri(std::string_view uri) {
    for (const auto& [prefix, kind] :
         {std::pair{node_prefix, Kind::node}, std::pair{names_prefix, Kind::names}}) {
        if (uri.size() > prefix.size() && uri.substr(0, prefix.size()) == prefix)
            return Subject{kind, std::string(uri.substr(prefix.size()))};
    }
    return std::nullopt;
}

Result<Identity> Identity::load(const std::string& directory) {
    Identity identity;
    identity.directory_ = directory;
    const std::string made_by = " (`plexus pki issue NODE --ca CA_DIR` makes an identity directory)";
    auto ca = read_certificate(identity.ca_file());
    if (!ca)
        return Error{"identity " + directory + ": cannot read the CA certificate ca.crt" + made_by};
    auto certificate = read_certificate(identity.certificate_file());
    if (!certificate)
        return Error{"identity " + directory + ": cannot read the certificate node.crt" + made_by};
    struct stat key_status {};
    if (::stat(identity.key_file().c_str(), &key_status) != 0)
        return Error{"identity " + directory + ": no private key node.key" + made_by};
    if ((key_status.st_mode & 077) != 0)
        return Error{"identity " + directory + ": node.key may be read by others (chmod 600 " +
                     identity.key_file() + ")"};
    auto key = read_private_key(identity.key_file());
    if (!key)
        return Error{"identity " + directory + ": cannot read the private key node.key"};
    if (::X509_check_private_key(certificate.get(), key.get()) != 1) {
        last_tls_error();
        return Error{"identity " + directory + ": node.key is not the key of node.crt"};
    }
    KeyPtr ca_key(::X509_get_pubkey(ca.get()));
    if (!ca_key || ::X509_verify(certificate.get(), ca_key.get()) != 1) {
        last_tls_error();
        return Error{"identity " + directory + ": node.crt was not issued by the CA of ca.crt"};
    }
    auto subject = subject_of(certificate.get());
    if (!subject)
        return Error{"identity " + directory + ": node.crt names no Plexus node (no plexus:node: URI)"};
    identity.subject_ = *subject;
    return identity;
}

std::int64_t Identity::crl_changed() const {
    struct stat status {};
    if (::stat(crl_file().c_str(), &status) != 0)
        return 0;
    return std::int64_t{status.st_mtim.tv_sec} * 1'000'000'000 + status.st_mtim.tv_nsec;
}

namespace {
/// A TLS 1.3 context that shows `identity`'s certificate.
std::unique_ptr<SSL_CTX, decltype(&::SSL_CTX_free)> showing(const Identity& identity) {
    std::unique_ptr<SSL_CTX, decltype(&::SSL_CTX_free)> context(new_tls13_context(), ::SSL_CTX_free);
    if (::SSL_CTX_use_certificate_file(context.get(), identity.certificate_file().c_str(),
                                       SSL_FILETYPE_PEM) != 1)
        fail(identity, "node.crt");
    if (::SSL_CTX_use_PrivateKey_file(context.get(), identity.key_file().c_str(), SSL_FILETYPE_PEM) != 1)
        fail(identity, "node.key");
    return context;
}
}  // namespace

ssl_ctx_st* new_certificate_tls_context(const Identity& identity) {
    auto context = showing(identity);
    SSL_CTX* ctx = context.get();
    if (::SSL_CTX_load_verify_locations(ctx, identity.ca_file().c_str(), nullptr) != 1)
        fail(identity, "ca.crt");
    // Only the deployment's CA is trusted: not the system's.
    if (std::filesystem::exists(identity.crl_file())) {
        auto crl = read_crl(identity.crl_file());
        if (!crl)
            fail(identity, "crl.pem");
        X509_STORE* store = ::SSL_CTX_get_cert_store(ctx);
        if (::X509_STORE_add_crl(store, crl.get()) != 1)
            fail(identity, "crl.pem");
        ::X509_STORE_set_flags(store, X509_V_FLAG_CRL_CHECK);
    }
    // Both ends show a certificate: a server asks for the client's and refuses a client without.
    ::SSL_CTX_set_verify(ctx, SSL_VERIFY_PEER | SSL_VERIFY_FAIL_IF_NO_PEER_CERT, nullptr);
    return context.release();
}

ssl_ctx_st* new_web_tls_context(const Identity& identity) {
    return showing(identity).release();
}

std::optional<Subject> peer_subject(ssl_st* session) {
    X509* certificate = ::SSL_get0_peer_certificate(session);
    if (!certificate || ::SSL_get_verify_result(session) != X509_V_OK)
        return std::nullopt;
    return subject_of(certificate);
}

bool revoked_now(const Identity& identity, X509* certificate) {
    // The lists read, by file: every link of a process asks about the same one or two, every second.
    struct Read {
        std::int64_t changed = -1;
        CrlPtr crl;
    };
    static std::mutex lock;
    static std::map<std::string, Read> lists;
    const std::int64_t changed = identity.crl_changed();
    if (changed == 0 || !certificate)
        return false;
    const std::lock_guard guard(lock);
    auto& list = lists[identity.crl_file()];
    if (list.changed != changed) {
        list.changed = changed;
        auto crl = read_crl(identity.crl_file());
        const auto ca = read_certificate(identity.ca_file());
        EVP_PKEY* ca_key = ca ? ::X509_get0_pubkey(ca.get()) : nullptr;
        if (crl && ca_key && ::X509_CRL_verify(crl.get(), ca_key) == 1)
            list.crl = std::move(crl);
        // Else the list read before stays: a half-written or foreign file takes nothing back.
        ::ERR_clear_error();
    }
    X509_REVOKED* entry = nullptr;
    return list.crl && ::X509_CRL_get0_by_cert(list.crl.get(), &entry, certificate) == 1;
}

Result<std::optional<Identity>> identity_from_environment() {
    const char* directory = std::getenv("PLEXUS_IDENTITY");
    if (!directory || !*directory)
        return std::optional<Identity>{};
    auto identity = Identity::load(directory);
    if (!identity)
        return Error{"PLEXUS_IDENTITY: " + identity.error().message};
    return std::optional<Identity>{std::move(*identity)};
}

}  // namespace plexus::proto
