#pragma once
// Threading: pure functions.
//
// A data frame whose payload is one large byte string (an image, a point cloud) can be received
// straight into the buffer of the Value the reader gets: recognised from its first bytes, the
// rest of it never passes through the connection's receive buffer. This saves two copies of the
// payload per message (into the shared block of records, then into the Value).

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string_view>

#include "plexus/client.hpp"
#include "plexus/proto/bytes.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::detail {

/// Frames at least this large are worth receiving straight into their message.
inline constexpr std::size_t large_payload_frame = 64 * 1024;

/// The body of the data frame that carries one message of `payload_size` bytes from `source`, with
/// the time and the handle at their widest: what the daemon compares with its max_frame.
inline std::size_t frame_body_size(std::string_view source, std::uint64_t seq, std::size_t payload_size) {
    constexpr auto widest = std::numeric_limits<std::uint64_t>::max();
    return proto::record_size(source, seq, widest, payload_size) + proto::max_varint_size;
}

struct LargePayloadFrame {
    std::uint64_t handle = 0;
    Envelope envelope;
    std::size_t payload_offset = 0;  ///< of the byte string's content, from the frame's first byte
    std::size_t payload_size = 0;    ///< the content runs to the end of the frame
};

/// The head of an untagged CBOR byte string of definite length at the start of `bytes`.
struct ByteStringHead {
    std::uint64_t length = 0;   ///< of the content
    std::size_t head_size = 0;  ///< bytes of the head before the content
};
std::optional<ByteStringHead> parse_byte_string_head(proto::ByteView bytes);

/// Recognises a data frame of `frame_size` bytes (at least large_payload_frame) that carries one
/// CBOR byte string without a tag, from `start`, the frame's first bytes. Anything else, or a
/// start too short to tell, gives nullopt: such frames take the ordinary path, which also judges
/// malformed ones.
std::optional<LargePayloadFrame> parse_large_payload_frame(proto::ByteView start, std::size_t frame_size);

}  // namespace plexus::detail
