#pragma once
// Unsigned LEB128 varints: 7 bits per byte, low bits first, high bit set on every byte but the last.

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

/// The most bytes a 64-bit varint can take.
inline constexpr std::size_t max_varint_size = 10;

/// Appends `value` as a varint to `out`.
void append_varint(Bytes& out, std::uint64_t value);

/// Writes `value` as a varint at `out` (room for max_varint_size bytes) and returns the bytes used.
inline std::size_t write_varint(std::uint8_t* out, std::uint64_t value) {
    std::size_t used = 0;
    while (value >= 0x80) {
        out[used++] = static_cast<std::uint8_t>(value | 0x80);
        value >>= 7;
    }
    out[used++] = static_cast<std::uint8_t>(value);
    return used;
}

/// How many bytes `value` takes as a varint.
inline std::size_t varint_size(std::uint64_t value) {
    std::size_t size = 1;
    while (value >= 0x80) {
        value >>= 7;
        ++size;
    }
    return size;
}

enum class VarintStatus { ok, need_more, bad };

struct VarintDecode {
    VarintStatus status;
    std::uint64_t value = 0;  ///< valid when status == ok
    std::size_t used = 0;     ///< bytes consumed when status == ok
};

/// Decodes a varint from the start of `input`. `bad` when it runs past 10 bytes or overflows 64 bits;
/// `need_more` when `input` ends inside it. Inline: every field of every message goes through it.
inline VarintDecode decode_varint(ByteView input) {
    const std::uint8_t* bytes = input.data();
    if (!input.empty() && bytes[0] < 0x80)  // most lengths, counts and handles: one byte
        return {VarintStatus::ok, bytes[0], 1};
    if (input.size() >= 9) {
        // Eight bytes at once (every record's time is a nine-byte varint): the first byte without
        // a continuation bit ends it, and the 7-bit groups are packed together in three steps.
        std::uint64_t word;
        std::memcpy(&word, bytes, 8);
        if constexpr (std::endian::native == std::endian::big)
            word = __builtin_bswap64(word);
        const std::uint64_t ends = ~word & 0x8080808080808080ull;
        std::size_t used = 9;
        std::uint64_t last = 0;
        if (ends != 0) {
            used = static_cast<std::size_t>(std::countr_zero(ends) / 8 + 1);
            if (used < 8)
                word &= (std::uint64_t{1} << (8 * used)) - 1;
        } else if (bytes[8] < 0x80) {
            last = static_cast<std::uint64_t>(bytes[8]) << 56;
        } else {
            used = 0;  // ten bytes: the general path below checks the tenth
        }
        if (used != 0) {
            word &= 0x7f7f7f7f7f7f7f7full;
            word = (word & 0x007f007f007f007full) | ((word & 0x7f007f007f007f00ull) >> 1);
            word = (word & 0x00003fff00003fffull) | ((word & 0x3fff00003fff0000ull) >> 2);
            word = (word & 0x000000000fffffffull) | ((word & 0x0fffffff00000000ull) >> 4);
            return {VarintStatus::ok, word | last, used};
        }
    }
    // The first nine bytes carry 7 bits each and need no other check.
    const std::size_t plain = input.size() < max_varint_size - 1 ? input.size() : max_varint_size - 1;
    std::uint64_t value = 0;
    for (std::size_t i = 0; i < plain; ++i) {
        value |= static_cast<std::uint64_t>(bytes[i] & 0x7f) << (7 * i);
        if ((bytes[i] & 0x80) == 0)
            return {VarintStatus::ok, value, i + 1};
    }
    if (input.size() < max_varint_size)
        return {VarintStatus::need_more};  // input ended inside the varint (ten bytes always end it)
    // The tenth byte holds bit 63 only: anything more would not fit in 64 bits, and a
    // continuation bit there would make the varint longer than ten bytes. Both are refused as
    // soon as they are seen, without waiting for more input.
    const std::uint8_t last = bytes[max_varint_size - 1];
    if (last > 1)
        return {VarintStatus::bad};
    return {VarintStatus::ok, value | (static_cast<std::uint64_t>(last) << 63), max_varint_size};
}

}  // namespace plexus::proto
