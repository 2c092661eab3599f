#pragma once
// The hello exchange: each side's first frame. Carries the protocol version from day one.
//     fields = "PLXS" | varint version | string role | string node [| raw[32] nonce | u8 flags]
// The nonce and flags were appended within version 2 (a reader ignores what it does not know):
// flags bit 0 says the sender holds the deployment secret. Since TLS (PROTOCOL.md,
// "Authentication") a hello with a secret travels inside the TLS link the secret keys, and the
// nonce is no longer answered (the auth frame that answered it is retired).

#include <array>
#include <cstdint>
#include <string>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

inline constexpr std::uint32_t protocol_version = 2;
inline constexpr std::string_view hello_magic = "PLXS";

inline constexpr std::uint8_t hello_flag_secret = 0x01;

struct Hello {
    std::uint32_t version = protocol_version;
    std::string role;                      ///< "client", "daemon", "names", "cli" ...; at most 64 bytes
    std::string node;                      ///< sender's node name, may be empty; at most 255 bytes
    std::array<std::uint8_t, 32> nonce{};  ///< the challenge the other side must answer
    bool has_secret = false;               ///< the sender will prove it holds the secret
    /// The largest frame body the sender accepts (a daemon tells its clients, so that a writer can
    /// refuse a message that would not fit before sending anything); 0: not said (older peers).
    std::uint64_t max_frame = 0;
};

/// A whole hello frame.
Bytes encode_hello(const Hello& hello);
/// Decodes the fields of a hello frame. Refuses a wrong magic; does not judge the version.
Result<Hello> decode_hello(ByteView fields);

}  // namespace plexus::proto
