#pragma once
// Making keys and X.509 certificates (OpenSSL): the deployment CA's (`plexus pki`,
// tools/cli/pki.cpp) and the web endpoint's own when a daemon has the secret but no identity.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "plexus/proto/pem_files.hpp"

struct ssl_ctx_st;

namespace plexus::proto {

/// A new ECDSA P-256 key: what browsers take in a certificate (Chromium takes no Ed25519 one) and
/// cheap to verify (OpenSSL's P-256 code is constant-time and fast on x86-64). Null on failure.
KeyPtr new_key();

/// A certificate of `key` named `common_name`, signed over SHA-256 by `issuer_key` (self-signed
/// when `issuer` is null), valid from an hour ago (clocks differ) for `days`, with `extensions`
/// (an OpenSSL NID and its value in openssl.cnf's syntax). Null on failure (OpenSSL's queue says why).
X509Ptr make_certificate(std::uint64_t serial, const std::string& common_name, EVP_PKEY* key, X509* issuer,
                         EVP_PKEY* issuer_key, int days,
                         const std::vector<std::pair<int, std::string>>& extensions);

/// "AB:CD:..." : the SHA-256 of a certificate, as browsers show it.
std::string certificate_fingerprint(X509* certificate);

/// The web endpoint's TLS context with the secret alone: a new key and a self-signed certificate
/// naming `host` (an IP address), made at each start; `fingerprint` gets its SHA-256 for a person
/// to compare with what the browser shows before accepting it. Throws std::runtime_error with
/// OpenSSL's reason when it cannot be made.
ssl_ctx_st* new_self_signed_web_tls_context(const std::string& host, std::string& fingerprint);

}  // namespace plexus::proto
