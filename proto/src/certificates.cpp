#include "plexus/proto/certificates.hpp"

#include <arpa/inet.h>
#include <openssl/evp.h>
#include <openssl/rand.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>

#include <stdexcept>

#include "plexus/proto/tls_psk.hpp"

namespace plexus::proto {

namespace {

bool add_extension(X509* certificate, X509* issuer, int nid, const std::string& value) {
    X509V3_CTX context;
    X509V3_set_ctx_nodb(&context);
    X509V3_set_ctx(&context, issuer, certificate, nullptr, nullptr, 0);
    X509_EXTENSION* extension = ::X509V3_EXT_conf_nid(nullptr, &context, nid, value.c_str());
    if (!extension)
        return false;
    const bool added = ::X509_add_ext(certificate, extension, -1) == 1;
    ::X509_EXTENSION_free(extension);
    return added;
}

}  // namespace

X509Ptr make_certificate(std::uint64_t serial, const std::string& common_name, EVP_PKEY* key, X509* issuer,
                         EVP_PKEY* issuer_key, int days,
                         const std::vector<std::pair<int, std::string>>& extensions) {
    X509Ptr certificate(::X509_new());
    if (!certificate)
        return nullptr;
    X509* c = certificate.get();
    X509_NAME* name = ::X509_get_subject_name(c);
    const bool made = ::X509_set_version(c, X509_VERSION_3) == 1 &&
                      ::ASN1_INTEGER_set_uint64(::X509_get_serialNumber(c), serial) == 1 &&
                      ::X509_gmtime_adj(::X509_getm_notBefore(c), -3600) != nullptr &&
                      ::X509_time_adj_ex(::X509_getm_notAfter(c), days, 0, nullptr) != nullptr &&
                      ::X509_NAME_add_entry_by_txt(
                          name, "CN", MBSTRING_UTF8,
                          reinterpret_cast<const unsigned char*>(common_name.c_str()), -1, -1, 0) == 1 &&
                      ::X509_set_issuer_name(c, issuer ? ::X509_get_subject_name(issuer) : name) == 1 &&
                      ::X509_set_pubkey(c, key) == 1;
    if (!made)
        return nullptr;
    for (const auto& [nid, value] : extensions) {
        if (!add_extension(c, issuer ? issuer : c, nid, value))
            return nullptr;
    }
    if (::X509_sign(c, issuer_key, ::EVP_sha256()) <= 0)
        return nullptr;
    return certificate;
}

KeyPtr new_key() {
    return KeyPtr(::EVP_PKEY_Q_keygen(nullptr, nullptr, "EC", "P-256"));
}

std::string certificate_fingerprint(X509* certificate) {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int size = 0;
    if (::X509_digest(certificate, ::EVP_sha256(), digest, &size) != 1)
        return "?";
    std::string text;
    for (unsigned int i = 0; i < size; ++i) {
        if (i > 0)
            text += ':';
        text += "0123456789ABCDEF"[digest[i] >> 4];
        text += "0123456789ABCDEF"[digest[i] & 15];
    }
    return text;
}

ssl_ctx_st* new_self_signed_web_tls_context(const std::string& host, std::string& fingerprint) {
    auto key = new_key();
    if (!key)
        throw std::runtime_error("cannot make the web endpoint's key: " + last_tls_error());
    unsigned char address[16];
    const bool is_ip =
        ::inet_pton(AF_INET, host.c_str(), address) == 1 || ::inet_pton(AF_INET6, host.c_str(), address) == 1;
    std::vector<std::pair<int, std::string>> extensions{{NID_basic_constraints, "critical,CA:FALSE"},
                                                        {NID_key_usage, "critical,digitalSignature"},
                                                        {NID_ext_key_usage, "serverAuth"}};
    if (is_ip)
        extensions.emplace_back(NID_subject_alt_name, "IP:" + host);
    // A random serial: two starts never show a browser two certificates with one serial.
    std::uint64_t serial = 0;
    ::RAND_bytes(reinterpret_cast<unsigned char*>(&serial), sizeof serial);
    auto certificate =
        make_certificate(serial >> 1, "plexusd web " + host, key.get(), nullptr, key.get(), 365, extensions);
    if (!certificate)
        throw std::runtime_error("cannot make the web endpoint's certificate: " + last_tls_error());
    fingerprint = certificate_fingerprint(certificate.get());
    std::unique_ptr<SSL_CTX, decltype(&::SSL_CTX_free)> context(new_tls13_context(), ::SSL_CTX_free);
    if (::SSL_CTX_use_certificate(context.get(), certificate.get()) != 1 ||
        ::SSL_CTX_use_PrivateKey(context.get(), key.get()) != 1)
        throw std::runtime_error("cannot use the web endpoint's certificate: " + last_tls_error());
    return context.release();
}

}  // namespace plexus::proto
