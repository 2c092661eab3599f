#pragma once
// The floor's wire format, shared by the relay and its clients: the least a message stream needs.
//
//     frame  = u32 body_length (little-endian) | body
//     body   = u64 seq (little-endian) | u64 send_time_ns (little-endian) | payload
//
// The relay looks at body_length only. seq and send_time_ns play the part of Plexus's envelope
// (which also carries the source port name), so that both systems move comparable bytes.

#include <cstddef>
#include <cstdint>

namespace plexus::bench::floor_frame {

inline constexpr std::size_t length_size = 4;
inline constexpr std::size_t envelope_size = 16;
/// seq value that tells an echoing client to stop.
inline constexpr std::uint64_t stop_seq = ~std::uint64_t{0};

inline void put_u32(std::uint8_t* out, std::uint32_t value) {
    for (int i = 0; i < 4; ++i)
        out[i] = static_cast<std::uint8_t>(value >> (8 * i));
}

inline void put_u64(std::uint8_t* out, std::uint64_t value) {
    for (int i = 0; i < 8; ++i)
        out[i] = static_cast<std::uint8_t>(value >> (8 * i));
}

inline std::uint32_t get_u32(const std::uint8_t* in) {
    std::uint32_t value = 0;
    for (int i = 0; i < 4; ++i)
        value |= static_cast<std::uint32_t>(in[i]) << (8 * i);
    return value;
}

inline std::uint64_t get_u64(const std::uint8_t* in) {
    std::uint64_t value = 0;
    for (int i = 0; i < 8; ++i)
        value |= static_cast<std::uint64_t>(in[i]) << (8 * i);
    return value;
}

}  // namespace plexus::bench::floor_frame
