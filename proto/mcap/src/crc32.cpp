#include "crc32.hpp"

#include <zlib.h>

#include <limits>

namespace plexus::mcap {

// zlib's crc32 is the same CRC (IEEE polynomial, reflected, inverted before and after) and, since
// 1.2.12, folds in several words at once; a recording checks every byte twice (its chunk's CRC,
// the data section's), so this is on the recorder's hot path (docs/BENCHMARKS.md, "Recording").
void Crc32::update(proto::ByteView bytes) {
    std::uint32_t value = state_ ^ 0xFFFFFFFFu;
    const std::uint8_t* data = bytes.data();
    std::size_t left = bytes.size();
    while (left > 0) {
        const auto piece = static_cast<uInt>(std::min<std::size_t>(left, std::numeric_limits<uInt>::max()));
        value = static_cast<std::uint32_t>(::crc32(value, data, piece));
        data += piece;
        left -= piece;
    }
    state_ = value ^ 0xFFFFFFFFu;
}

}  // namespace plexus::mcap
