#pragma once
// Control requests and replies: a varint id followed by a CBOR-encoded JSON map.
//     request fields = varint id | CBOR map  ({"op": "...", ...})
//     reply fields   = varint id | varint code | CBOR map  (code 0 = ok; else "error" holds the reason)

#include <cstdint>

#include <nlohmann/json.hpp>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

/// Reply codes. They match the CLI's exit statuses where a reply ends a command.
enum class ReplyCode : std::uint32_t {
    ok = 0,
    no = 1,     ///< a "no" answer (does not exist)
    usage = 2,  ///< the request itself is malformed
    timeout = 3,
    refused = 4,  ///< refused by the system; body["error"] says why
};

struct Request {
    std::uint64_t id = 0;
    nlohmann::json body;  ///< a map with at least "op"
};

struct Reply {
    std::uint64_t id = 0;
    ReplyCode code = ReplyCode::ok;
    nlohmann::json body;  ///< a map
};

Bytes encode_request(const Request& request);  ///< a whole frame
Bytes encode_reply(const Reply& reply);        ///< a whole frame
/// Decodes request fields; refuses CBOR that is not a map or lacks a string "op".
Result<Request> decode_request(ByteView fields);
/// Decodes reply fields; refuses CBOR that is not a map and unknown codes.
Result<Reply> decode_reply(ByteView fields);

/// A refusal with a reason, the common case.
Reply make_refusal(std::uint64_t id, ReplyCode code, std::string reason);

/// Deepest nesting of arrays and maps accepted from a peer. The decoder does not recurse, but what
/// later walks the json (dump, to_cbor, ==) does, and a 64 MiB frame can nest 64 million levels.
inline constexpr std::size_t max_cbor_depth = 128;

/// Decodes one CBOR value that fills `bytes` exactly. Never throws; refuses malformed CBOR,
/// trailing bytes and nesting deeper than max_depth. Use it for every CBOR that came off the wire.
/// It is decode_cbor_fast (cbor.hpp) with "bad CBOR: " before the reason.
Result<nlohmann::json> decode_cbor(ByteView bytes, std::size_t max_depth = max_cbor_depth);

}  // namespace plexus::proto
