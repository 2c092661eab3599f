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
/// It is also the limit of every value a writer may send (check_value_depth): what is accepted
/// where a value enters can be decoded by every reader.
inline constexpr std::size_t max_cbor_depth = 128;
/// A request or reply body wraps a value (a payload, a parameter) in a few maps of its own: bodies
/// are decoded with this much room so that any value within max_cbor_depth fits in one.
inline constexpr std::size_t max_body_depth = max_cbor_depth + 4;

/// How deeply `value` nests arrays and maps (a scalar is 0, `[]` is 1, `[[1]]` is 2), counted only
/// up to `stop_after` + 1 (recursing no deeper), so a hostile value costs no more than that.
std::size_t nesting_depth(const nlohmann::json& value, std::size_t stop_after = max_cbor_depth);
/// An Error ("VALUE nests arrays and maps deeper than 128 levels ...") when `value` could not be
/// decoded by a reader; `what` names it for the person ("the message", "parameter x").
Status check_value_depth(const nlohmann::json& value, const std::string& what);

/// Decodes one CBOR value that fills `bytes` exactly. Never throws; refuses malformed CBOR,
/// trailing bytes and nesting deeper than max_depth. Use it for every CBOR that came off the wire.
/// It is decode_cbor_fast (cbor.hpp) with "bad CBOR: " before the reason.
Result<nlohmann::json> decode_cbor(ByteView bytes, std::size_t max_depth = max_cbor_depth);

}  // namespace plexus::proto
