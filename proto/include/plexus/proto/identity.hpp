#pragma once
// A node's identity (docs/SECURITY.md, "Identities"): a certificate of the deployment's CA that
// names the node, and its private key. With identities, a deployment's TCP links are mutual TLS
// 1.3 with these certificates instead of the secret's pre-shared key: each end learns which node
// (or which name server) the other is, and a node can act only as the node its certificate names.
// A revocation list (crl.pem) refuses a certificate that was given out and must no longer be
// trusted (a machine that was stolen or broken into).
//
// An identity is a directory made by `plexus pki issue` (tools/cli/pki.cpp):
//   ca.crt    the deployment CA's certificate: the only issuer trusted
//   node.crt  this node's certificate; its subjectAltName URI says what it is:
//             "plexus:node:NAME" (a daemon, its CLI and its components) or "plexus:names:NAME"
//   node.key  its private key (ECDSA P-256), readable by its owner only
//   crl.pem   the CA's revocation list, read again whenever it changes

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "plexus/proto/bytes.hpp"

struct ssl_ctx_st;
struct ssl_st;
struct x509_st;

namespace plexus::proto {

/// What a certificate says its holder is.
struct Subject {
    enum class Kind { node, names };
    Kind kind = Kind::node;
    std::string name;

    /// "plexus:node:NAME" or "plexus:names:NAME".
    std::string uri() const;
    /// "node 'NAME'" or "name server 'NAME'", for messages.
    std::string text() const;
    /// The subject of a URI of uri()'s form; nullopt for anything else.
    static std::optional<Subject> from_uri(std::string_view uri);
    bool operator==(const Subject&) const = default;
};

/// This process's identity: where its files are, and what its certificate names.
class Identity {
public:
    /// Reads the directory: the certificate must be the CA's and name a subject, the key must be
    /// the certificate's and readable by its owner only (like an ssh key). An Error says which
    /// file is wrong and how to make a good one.
    static Result<Identity> load(const std::string& directory);

    const std::string& directory() const { return directory_; }
    const Subject& subject() const { return subject_; }
    std::string ca_file() const { return directory_ + "/ca.crt"; }
    std::string certificate_file() const { return directory_ + "/node.crt"; }
    std::string key_file() const { return directory_ + "/node.key"; }
    std::string crl_file() const { return directory_ + "/crl.pem"; }
    /// When crl.pem last changed, in nanoseconds since the epoch (0 when there is none): a TLS
    /// context made before is stale.
    std::int64_t crl_changed() const;

private:
    std::string directory_;
    Subject subject_;
};

/// A new OpenSSL context (SSL_CTX*, the caller frees it) for either end of a link between
/// identities: TLS 1.3 only, the same suites as the secret's links, this identity's certificate
/// and key, and the peer's certificate required and checked against ca.crt and crl.pem. Throws
/// std::runtime_error with OpenSSL's reason when a file cannot be used.
ssl_ctx_st* new_certificate_tls_context(const Identity& identity);

/// A new OpenSSL context (SSL_CTX*, the caller frees it) for the web endpoint's HTTPS: TLS 1.3,
/// this identity's certificate and key, no client certificate asked for (a browser has none; the
/// web token is the check). A browser takes the certificate when it names the host it asked for
/// (`plexus pki issue NODE --web HOST`) and trusts the deployment's CA.
ssl_ctx_st* new_web_tls_context(const Identity& identity);

/// What the peer's certificate (checked during the handshake) names; nullopt when the session has
/// no peer certificate (a pre-shared key) or it names no Plexus subject.
std::optional<Subject> peer_subject(ssl_st* session);

/// Whether `certificate` (a peer's, checked at its handshake) is on `identity`'s revocation list as
/// the list is now: for links made before a revocation, which a new handshake would refuse. crl.pem
/// is read again only when it changed, and taken only when ca.crt signed it (a list that is not the
/// CA's is ignored, as the handshake's check would refuse it). Thread-safe.
bool revoked_now(const Identity& identity, x509_st* certificate);

/// The PLEXUS_IDENTITY directory of a CLI or component, loaded; nullopt when the variable is not
/// set. An Error when it names an identity that cannot be used.
Result<std::optional<Identity>> identity_from_environment();

}  // namespace plexus::proto
