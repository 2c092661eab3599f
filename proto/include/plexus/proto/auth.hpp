#pragma once
// The deployment secret and what is made from it (docs/SECURITY.md): proofs that a TCP peer holds
// the secret (HMAC challenge-response after the hello exchange), and MACs of datagrams.
// HMAC-SHA256 by OpenSSL's libcrypto: Debian's maintained build, which uses the CPU's SHA
// instructions where they exist (1.5 GB/s for SHA-256 on the test VM), with a constant-time
// compare (CRYPTO_memcmp) and the kernel's random numbers (RAND_bytes). The secret itself never
// leaves the process.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

inline constexpr std::size_t auth_nonce_size = 32;
inline constexpr std::size_t auth_proof_size = 32;
/// A secret shorter than this is refused: it could be guessed.
inline constexpr std::size_t min_secret_size = 16;

using Nonce = std::array<std::uint8_t, auth_nonce_size>;

/// Which end of a TCP connection proves: the proofs of the two ends are made with different
/// labels, so a proof one end sends can never be handed back to it as the other end's (a peer
/// without the secret opening two connections and reflecting one's proof into the other).
enum class Party { connecting, accepting };
using Proof = std::array<std::uint8_t, auth_proof_size>;

/// The deployment secret, and keys derived from it. Cheap to share (a shared pointer inside).
class Secret {
public:
    /// Reads a secret file: its bytes, less one trailing newline. Refused when the file cannot be
    /// read, is readable by group or others (like an ssh key), or is shorter than min_secret_size.
    static Result<Secret> load(const std::string& path);
    /// A secret from bytes (tests).
    static Result<Secret> from_bytes(std::string_view bytes);

    /// What a peer sends to prove it holds the secret: HMAC(secret, label | the other side's nonce |
    /// its own nonce | its role | its node). Binding both nonces makes a proof useless on any
    /// other connection; binding role and node makes it useless for anyone else's hello.
    Proof prove(Party party, const Nonce& challenge, const Nonce& own, std::string_view role,
                std::string_view node) const;
    /// The MAC of a datagram (HMAC with a key derived for datagrams, cut to 16 bytes) over `head`
    /// followed by `body` (a sender's header and fragment lie apart).
    void datagram_mac(ByteView head, ByteView body, std::uint8_t* out16) const;
    void datagram_mac(ByteView signed_part, std::uint8_t* out16) const {
        datagram_mac(signed_part, {}, out16);
    }
    /// Checks a datagram's MAC in constant time.
    bool datagram_mac_ok(ByteView signed_part, ByteView mac) const;
    /// The key of the deployment's TLS links (tls_psk.hpp): HMAC(secret, "plexus tls psk v1").
    Proof tls_key() const;
    /// The web endpoint's token (docs/WEB.md): hex of HMAC(secret, "plexus web token v1"). A person
    /// enters it once in a browser; it opens the read-only views and nothing else, so it is not the
    /// secret, and the secret cannot be found from it.
    std::string web_token() const;

private:
    struct Keys;
    std::shared_ptr<const Keys> keys_;
};

/// Fresh random bytes from the kernel.
Nonce random_nonce();
/// Compares in time that does not depend on where they differ.
bool same_proof(const Proof& a, ByteView b);
/// Compares two texts (tokens) in time that does not depend on where they differ.
bool same_text(std::string_view a, std::string_view b);

}  // namespace plexus::proto
