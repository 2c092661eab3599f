#pragma once
// Unsigned LEB128 varints: 7 bits per byte, low bits first, high bit set on every byte but the last.

#include <cstddef>
#include <cstdint>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

/// The most bytes a 64-bit varint can take.
inline constexpr std::size_t max_varint_size = 10;

/// Appends `value` as a varint to `out`.
void append_varint(Bytes& out, std::uint64_t value);

/// Writes `value` as a varint at `out` (room for max_varint_size bytes) and returns the bytes used.
std::size_t write_varint(std::uint8_t* out, std::uint64_t value);

/// How many bytes `value` takes as a varint.
std::size_t varint_size(std::uint64_t value);

enum class VarintStatus { ok, need_more, bad };

struct VarintDecode {
    VarintStatus status;
    std::uint64_t value = 0;  ///< valid when status == ok
    std::size_t used = 0;     ///< bytes consumed when status == ok
};

/// Decodes a varint from the start of `input`. `bad` when it runs past 10 bytes or overflows 64 bits;
/// `need_more` when `input` ends inside it.
VarintDecode decode_varint(ByteView input);

}  // namespace plexus::proto
