#include "crc32.hpp"

#include <array>
#include <cstring>

namespace plexus::mcap {

namespace {

// tables[k][b]: the CRC of byte b followed by k zero bytes, so eight input bytes are folded in
// with eight lookups and no per-bit work ("slicing by 8").
using Tables = std::array<std::array<std::uint32_t, 256>, 8>;

constexpr Tables make_tables() {
    Tables tables{};
    for (std::uint32_t byte = 0; byte < 256; ++byte) {
        std::uint32_t crc = byte;
        for (int bit = 0; bit < 8; ++bit)
            crc = (crc & 1u) ? (crc >> 1) ^ 0xEDB88320u : crc >> 1;
        tables[0][byte] = crc;
    }
    for (std::size_t k = 1; k < 8; ++k)
        for (std::size_t byte = 0; byte < 256; ++byte)
            tables[k][byte] = (tables[k - 1][byte] >> 8) ^ tables[0][tables[k - 1][byte] & 0xFFu];
    return tables;
}

constexpr Tables tables = make_tables();

}  // namespace

void Crc32::update(proto::ByteView bytes) {
    std::uint32_t crc = state_;
    const std::uint8_t* at = bytes.data();
    std::size_t left = bytes.size();
    while (left >= 8) {
        // Assembled byte by byte rather than loaded: the layout does not depend on endianness.
        const std::uint32_t low = crc ^ (std::uint32_t{at[0]} | std::uint32_t{at[1]} << 8 |
                                         std::uint32_t{at[2]} << 16 | std::uint32_t{at[3]} << 24);
        crc = tables[7][low & 0xFFu] ^ tables[6][(low >> 8) & 0xFFu] ^ tables[5][(low >> 16) & 0xFFu] ^
              tables[4][low >> 24] ^ tables[3][at[4]] ^ tables[2][at[5]] ^ tables[1][at[6]] ^
              tables[0][at[7]];
        at += 8;
        left -= 8;
    }
    while (left-- > 0)
        crc = (crc >> 8) ^ tables[0][(crc ^ *at++) & 0xFFu];
    state_ = crc;
}

}  // namespace plexus::mcap
