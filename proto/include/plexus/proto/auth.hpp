#pragma once
// The deployment secret and what is made from it (docs/SECURITY.md): the key of the deployment's
// TLS links (tls_psk.hpp), the web endpoint's token, and the proofs on discovery answers.
// HMAC-SHA256 by OpenSSL's libcrypto, with a constant-time compare (CRYPTO_memcmp). The secret
// itself never leaves the process, and nothing is keyed by it directly but these HMACs.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

class Identity;

/// A secret shorter than this is refused: it could be guessed.
inline constexpr std::size_t min_secret_size = 16;

/// Which end of a TCP link this is: the TLS client (it connected) or the TLS server (it accepted).
enum class Party { connecting, accepting };
/// An HMAC-SHA256: a key made from the secret, or a proof.
using Digest = std::array<std::uint8_t, 32>;

/// The deployment secret, and keys derived from it. Cheap to share (a shared pointer inside).
class Secret {
public:
    /// Reads a secret file: its bytes, less one trailing newline. Refused when the file cannot be
    /// read, is readable by group or others (like an ssh key), or is shorter than min_secret_size.
    static Result<Secret> load(const std::string& path);
    /// A secret from bytes (tests).
    static Result<Secret> from_bytes(std::string_view bytes);

    /// The key of the deployment's TLS links (tls_psk.hpp): HMAC(secret, "plexus tls psk v1").
    Digest tls_key() const;
    /// The web endpoint's token (docs/WEB.md): hex of HMAC(secret, "plexus web token v1"). A person
    /// enters it once in a browser; it opens the read-only views and nothing else, so it is not the
    /// secret, and the secret cannot be found from it.
    std::string web_token() const;
    /// What a name server adds to its discovery answer to show it holds the secret (discovery.hpp):
    /// hex of HMAC(secret, "plexus discovery v1" | the query's nonce | the answered address).
    std::string discovery_proof(std::string_view nonce, std::string_view address) const;

    /// This process's identity (identity.hpp), when the deployment gives its nodes certificates:
    /// its TCP links are then mutual TLS with the certificates rather than TLS keyed by the secret,
    /// which still proves discovery answers and makes the web token. Identities come on top of the
    /// secret, never instead of it.
    void set_identity(const Identity& identity);
    /// nullptr without one.
    const Identity* identity() const { return identity_.get(); }

private:
    std::shared_ptr<const Bytes> secret_;
    std::shared_ptr<const Identity> identity_;
};

/// Compares two texts (tokens, proofs) in time that does not depend on where they differ.
bool same_text(std::string_view a, std::string_view b);

}  // namespace plexus::proto
