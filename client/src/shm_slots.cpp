#include "shm_slots.hpp"

namespace plexus::detail {

namespace {
// Slots start on cache lines: two payloads never share one, and copies start aligned.
constexpr std::size_t alignment = 64;

std::size_t aligned(std::size_t offset) {
    return (offset + alignment - 1) / alignment * alignment;
}
}  // namespace

std::optional<std::size_t> ShmSlots::allocate(std::size_t length) {
    if (length == 0 || length > size_)
        return std::nullopt;
    std::size_t gap_start = 0;
    for (const auto& [offset, used] : slots_) {
        if (offset - gap_start >= length)
            break;
        gap_start = aligned(offset + used);
    }
    if (gap_start > size_ || size_ - gap_start < length)
        return std::nullopt;
    slots_.emplace(gap_start, length);
    return gap_start;
}

bool ShmSlots::free(std::size_t offset) {
    return slots_.erase(offset) == 1;
}

}  // namespace plexus::detail
