#pragma once
// Reading a counter or size out of a daemon's JSON answer for display.

#include <cstdint>

#include "plexus/client.hpp"

namespace plexus::cli {

/// `object[key]` as an unsigned 64-bit count, 0 when absent. Not `value(key, 0)`: its int default
/// makes nlohmann convert to int, which cut a queue of 99999999999 to 32 bits in `plexus stats`
/// and showed 2^64-5 as -5.
inline std::uint64_t counter(const Value& object, const char* key) {
    return object.value(key, std::uint64_t{0});
}

}  // namespace plexus::cli
