#pragma once
// CRC-32 as MCAP uses it (the IEEE/zlib polynomial 0xEDB88320, reflected, initial and final
// value 0xFFFFFFFF). Computed eight bytes at a time: chunks of megabytes are checked on every read.

#include <cstdint>

#include "plexus/proto/bytes.hpp"

namespace plexus::mcap {

/// A running CRC32: feed it bytes in pieces, read value() at any time.
class Crc32 {
public:
    /// Continues from the CRC `value` of the bytes before (0 for none).
    explicit Crc32(std::uint32_t value = 0) : state_(value ^ 0xFFFFFFFFu) {}
    void update(proto::ByteView bytes);
    std::uint32_t value() const { return state_ ^ 0xFFFFFFFFu; }

private:
    std::uint32_t state_;
};

/// The CRC32 of `bytes`.
inline std::uint32_t crc32(proto::ByteView bytes) {
    Crc32 crc;
    crc.update(bytes);
    return crc.value();
}

}  // namespace plexus::mcap
