#pragma once
// Bytes as hexadecimal text and back: keys, tokens and proofs travel so in JSON and in files.

#include <string>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

/// Two lowercase hexadecimal digits per byte.
inline std::string hex_text(ByteView bytes) {
    static constexpr char digits[] = "0123456789abcdef";
    std::string text;
    text.reserve(2 * bytes.size());
    for (const std::uint8_t byte : bytes) {
        text.push_back(digits[byte >> 4]);
        text.push_back(digits[byte & 0x0f]);
    }
    return text;
}

/// The value of one hexadecimal digit (either case); -1 for any other character.
inline int hex_digit_value(char c) {
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

}  // namespace plexus::proto
