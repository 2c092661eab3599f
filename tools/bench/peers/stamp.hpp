#pragma once
// The first bytes of every message the peers scenarios send: what it is, its sequence number and
// when it was sent. The rest of the payload is filler up to the message size. The steady clock is
// CLOCK_MONOTONIC, one clock for every process of the machine, so a receiver in another process
// (the far ends of DDS and iceoryx) subtracts the sender's stamp from its own reading of it.

#include <chrono>
#include <cstdint>
#include <cstring>
#include <string>

namespace plexus::bench::peers {

enum class Kind : std::uint32_t {
    warm_up = 1,  ///< sent until every subscriber has seen one; ignored afterwards
    data = 2,     ///< measured
};

struct Stamp {
    Kind kind = Kind::data;
    std::uint32_t reserved = 0;
    std::uint64_t seq = 0;
    std::int64_t send_ns = 0;  ///< steady clock
};

inline constexpr std::size_t min_message_size = sizeof(Stamp);

inline std::int64_t steady_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

/// Writes `stamp` at the start of `message` (which is at least min_message_size long).
inline void put_stamp(std::string& message, const Stamp& stamp) {
    std::memcpy(message.data(), &stamp, sizeof stamp);
}

/// Reads the stamp of a received message; kind is 0 (neither warm-up nor data) if it is too short.
inline Stamp get_stamp(const std::string& message) {
    Stamp stamp{};
    stamp.kind = Kind{0};
    if (message.size() >= sizeof stamp)
        std::memcpy(&stamp, message.data(), sizeof stamp);
    return stamp;
}

}  // namespace plexus::bench::peers
