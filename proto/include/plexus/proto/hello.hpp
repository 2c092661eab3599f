#pragma once
// The hello exchange: each side's first frame. Carries the protocol version from day one.
//     fields = "PLXS" | varint version | string role | string node

#include <cstdint>
#include <string>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

inline constexpr std::uint32_t protocol_version = 2;
inline constexpr std::string_view hello_magic = "PLXS";

struct Hello {
    std::uint32_t version = protocol_version;
    std::string role;  ///< "client", "daemon", "names", "cli" ...; at most 64 bytes
    std::string node;  ///< sender's node name, may be empty; at most 255 bytes
};

/// A whole hello frame.
Bytes encode_hello(const Hello& hello);
/// Decodes the fields of a hello frame. Refuses a wrong magic; does not judge the version.
Result<Hello> decode_hello(ByteView fields);

}  // namespace plexus::proto
