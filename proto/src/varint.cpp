#include "plexus/proto/varint.hpp"

#include <array>
#include <cstddef>

namespace plexus::proto {

void append_varint(Bytes& out, std::uint64_t value) {
    std::array<std::uint8_t, max_varint_size> buffer{};
    const std::size_t used = write_varint(buffer.data(), value);
    out.insert(out.end(), buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(used));
}

}  // namespace plexus::proto
