#pragma once
// A CBOR (RFC 8949) to nlohmann::json decoder for bytes that came off the wire: it builds the same
// json as nlohmann::json::from_cbor for everything nlohmann::json::to_cbor writes, copies strings
// with one memcpy instead of a byte at a time, checks every declared length against the bytes left
// before allocating, and keeps its own stack, so no input can make it recurse.
//
// Where it departs from from_cbor (none of these are written by to_cbor except the first):
//   - tags 0xd8-0xdb followed by a byte string are nlohmann's binary subtype and are accepted
//     (from_cbor refuses every tag unless told to store them); every other tag is refused;
//   - a negative integer below INT64_MIN is refused (from_cbor wraps it into a wrong value);
//   - a chunk of an indefinite-length string must be a definite-length string (RFC 8949 3.2.3;
//     from_cbor also accepts nested indefinite chunks, and recurses on them);
//   - an array or map that declares 2^64-1 elements is refused as too long (from_cbor reads it
//     as indefinite-length).

#include <cstddef>

#include <nlohmann/json.hpp>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/control.hpp"

namespace plexus::proto {

/// Decodes one CBOR value that fills `bytes` exactly. Never throws; refuses malformed or truncated
/// CBOR, declared lengths longer than the input, trailing bytes and nesting of arrays and maps
/// deeper than max_depth, with a reason that names the byte offset.
Result<nlohmann::json> decode_cbor_fast(ByteView bytes, std::size_t max_depth = max_cbor_depth);

/// Appends `value` as CBOR, byte for byte what nlohmann::json::to_cbor writes. Byte strings
/// (without a subtype) and text strings, the payloads of raw streams, are written directly; other
/// values go through to_cbor.
void encode_cbor(const nlohmann::json& value, Bytes& out);

/// Appends the head of a CBOR byte string of `size` bytes (what encode_cbor writes before the
/// bytes of a binary value without a subtype): a writer can then send the bytes from where they are.
void append_byte_string_head(Bytes& out, std::size_t size);

}  // namespace plexus::proto
