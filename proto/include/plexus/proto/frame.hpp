#pragma once
// Frames: the unit of every Plexus stream. Layout (see proto/PROTOCOL.md):
//     varint body_length | body
//     body = u8 frame_type | type-specific fields
// body_length counts the type byte. It is checked against the decoder's maximum before the caller
// allocates anything for the body.

#include <cstddef>
#include <cstdint>
#include <string>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

enum class FrameType : std::uint8_t {
    hello = 1,       ///< first frame each side sends: magic, protocol version, role, node
    request = 2,     ///< varint id | CBOR map (a control request)
    reply = 3,       ///< varint id | varint code | CBOR map
    data = 4,        ///< varint handle | message record (see message.hpp)
    error = 5,       ///< string reason; the sender closes the connection after it
    data_batch = 6,  ///< varint handle | varint count | count x (varint length | record)
    // Shared memory between a client and its local daemon (see shm.hpp): large payloads are
    // written once into a region and only their place travels in the socket.
    data_shm = 7,          ///< varint handle | varint region | varint offset | varint length | record head
    shm_region = 8,        ///< daemon -> client: varint region | varint size | u8 writable; carries an fd
    shm_release = 9,       ///< client -> daemon: varint count (the oldest data_shm frames it was sent)
    shm_free = 10,         ///< daemon -> writer: varint region | varint offset (a slot is free again)
    shm_region_gone = 11,  ///< daemon -> reader: varint region (no more messages from it: unmap, close)
    auth = 12,             ///< raw[32] proof of the deployment secret, right after the hello (TCP)
    // Request/reply (see call.hpp): a message that wants one answer, and its answer.
    call = 13,    ///< varint handle | varint id | varint timeout_ms | record
    answer = 14,  ///< varint id | u8 outcome | record, or string reason
    // Shared-memory rings (see rings.hpp): the session's frames leave the Unix socket for two rings.
    rings = 15,  ///< client: varint ring_bytes; daemon: varint ring_bytes | string reason, + 5 fds
};

/// Default largest body accepted: 64 MiB, enough for large blobs, far below what a lie could ask for.
inline constexpr std::size_t default_max_frame = 64u * 1024u * 1024u;

/// Largest request body accepted, whatever the frame limit: requests carry parameters, never data,
/// and a decoded CBOR body costs up to 16 times its size (a 64 MiB array of zeros is 1 GiB of json).
inline constexpr std::size_t max_request_frame = 1024u * 1024u;

enum class DecodeStatus { frame, need_more, bad };

struct FrameDecode {
    DecodeStatus status;
    FrameType type{};        ///< valid when status == frame
    ByteView fields;         ///< the body after the type byte, a view into the input; when status == frame
    std::size_t used = 0;    ///< bytes of the input this frame took; when status == frame
    std::size_t needed = 0;  ///< when need_more: total input size needed to make progress (at least input+1)
    std::string error;       ///< when bad: why, e.g. "frame length 4294967296 exceeds limit 67108864"
};

/// Decodes one frame from the start of a contiguous buffer; keeps no state between calls.
/// `bad` for a length of 0 or over max_body (over max_request_frame for a request), a broken length
/// varint, or an unknown frame type.
class FrameDecoder {
public:
    explicit FrameDecoder(std::size_t max_body = default_max_frame) : max_body_(max_body) {}
    FrameDecode decode(ByteView input) const;
    std::size_t max_body() const { return max_body_; }

private:
    std::size_t max_body_;
};

/// Appends the header (length and type) of a frame whose fields take `fields_size` bytes.
void append_frame_header(Bytes& out, FrameType type, std::size_t fields_size);

/// Appends a whole frame.
void append_frame(Bytes& out, FrameType type, ByteView fields);

/// Longest error reason carried by an error frame; make_error_frame cuts longer ones.
inline constexpr std::size_t max_error_reason = 4096;

/// Frames an error reason (the peer is told why before the connection closes).
Bytes make_error_frame(std::string_view reason);

/// Decodes the fields of an error frame: the reason.
Result<std::string> decode_error(ByteView fields);

/// Human name of a frame type for logs ("hello", "data", or "unknown(9)").
std::string frame_type_name(std::uint8_t type);

}  // namespace plexus::proto
