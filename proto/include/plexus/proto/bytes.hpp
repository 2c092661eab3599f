#pragma once
// Byte buffers and a small result type shared by the whole wire layer.

#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace plexus::proto {

using Bytes = std::vector<std::uint8_t>;
using ByteView = std::span<const std::uint8_t>;

/// The unsigned number in the `width` (1, 2, 4 or 8) big-endian bytes at `at`: CBOR's arguments,
/// read with one load and a byte swap rather than a loop (the monitors' per-message path).
inline std::uint64_t read_big_endian(const std::uint8_t* at, std::size_t width) {
    static_assert(std::endian::native == std::endian::little || std::endian::native == std::endian::big);
    constexpr bool swap = std::endian::native == std::endian::little;
    switch (width) {
        case 1:
            return at[0];
        case 2: {
            std::uint16_t value;
            std::memcpy(&value, at, 2);
            return swap ? __builtin_bswap16(value) : value;
        }
        case 4: {
            std::uint32_t value;
            std::memcpy(&value, at, 4);
            return swap ? __builtin_bswap32(value) : value;
        }
        default: {
            std::uint64_t value;
            std::memcpy(&value, at, 8);
            return swap ? __builtin_bswap64(value) : value;
        }
    }
}

/// A failure that explains itself: the text is meant for a user or a peer.
struct Error {
    std::string message;
};

/// Either a value or an Error (std::expected is C++23; this is the part of it we need).
template <typename T>
class Result {
public:
    Result(T value) : state_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
    Result(Error error) : state_(std::move(error)) {}  // NOLINT(google-explicit-constructor)
    bool ok() const { return state_.index() == 0; }
    explicit operator bool() const { return ok(); }
    T& value() { return std::get<0>(state_); }
    const T& value() const { return std::get<0>(state_); }
    T& operator*() { return value(); }
    const T& operator*() const { return value(); }
    T* operator->() { return &value(); }
    const T* operator->() const { return &value(); }
    const Error& error() const { return std::get<1>(state_); }

private:
    std::variant<T, Error> state_;
};

/// Result for operations that only succeed or fail.
struct Ok {};
using Status = Result<Ok>;

inline std::string_view as_string_view(ByteView bytes) {
    return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}
inline ByteView as_bytes(std::string_view text) {
    return {reinterpret_cast<const std::uint8_t*>(text.data()), text.size()};
}

}  // namespace plexus::proto
