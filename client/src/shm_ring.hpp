#pragma once
// Threading: none; the connection guards it with its shm mutex.

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>

namespace plexus::detail {

/// Hands out slots of a shared-memory region for payloads, in the order they are written, and takes
/// them back in any order (several readers release at their own pace). Next fit: a slot starts
/// where the last one ended, wrapping to the start when the end has no room; a gap left by a slot
/// freed early is reused when the ring comes round to it.
class ShmRing {
public:
    explicit ShmRing(std::size_t size) : size_(size) {}

    /// A slot of `length` bytes, or nullopt when no gap is that large now.
    std::optional<std::size_t> allocate(std::size_t length);
    /// Gives back the slot at `offset`; false if there is none there.
    bool free(std::size_t offset);
    /// Slots handed out and not yet freed.
    std::size_t used() const { return slots_.size(); }

private:
    /// True when [offset, offset + length) lies in the region and overlaps no slot.
    bool fits(std::size_t offset, std::size_t length) const;

    std::size_t size_;
    std::size_t next_ = 0;                     ///< where the last slot ended
    std::map<std::size_t, std::size_t> slots_; ///< offset -> length of the slots in use
};

}  // namespace plexus::detail
