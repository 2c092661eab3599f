#include "plexus/proto/varint.hpp"

#include <array>
#include <cstddef>

namespace plexus::proto {

void append_varint(Bytes& out, std::uint64_t value) {
    std::array<std::uint8_t, max_varint_size> buffer{};
    const std::size_t used = write_varint(buffer.data(), value);
    out.insert(out.end(), buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(used));
}

std::size_t write_varint(std::uint8_t* out, std::uint64_t value) {
    std::size_t used = 0;
    while (value >= 0x80) {
        out[used++] = static_cast<std::uint8_t>(value | 0x80);
        value >>= 7;
    }
    out[used++] = static_cast<std::uint8_t>(value);
    return used;
}

std::size_t varint_size(std::uint64_t value) {
    std::size_t size = 1;
    while (value >= 0x80) {
        value >>= 7;
        ++size;
    }
    return size;
}

}  // namespace plexus::proto
