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

VarintDecode decode_varint(ByteView input) {
    std::uint64_t value = 0;
    for (std::size_t i = 0; i < max_varint_size; ++i) {
        if (i == input.size()) {
            return {VarintStatus::need_more};
        }
        const std::uint8_t byte = input[i];
        const std::uint64_t bits = byte & 0x7f;
        // The tenth byte holds bit 63 only: anything more would not fit in 64 bits, and a
        // continuation bit there would make the varint longer than ten bytes. Both are refused
        // as soon as they are seen, without waiting for more input.
        if (i == max_varint_size - 1 && ((byte & 0x80) != 0 || bits > 1)) {
            return {VarintStatus::bad};
        }
        value |= bits << (7 * i);
        if ((byte & 0x80) == 0) {
            return {VarintStatus::ok, value, i + 1};
        }
    }
    return {VarintStatus::bad};  // not reached: the tenth byte either ends the varint or is refused
}

}  // namespace plexus::proto
