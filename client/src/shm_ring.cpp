#include "shm_ring.hpp"

#include <iterator>

namespace plexus::detail {

namespace {
// Slots start on cache lines: two payloads never share one, and copies start aligned.
constexpr std::size_t alignment = 64;
}  // namespace

bool ShmRing::fits(std::size_t offset, std::size_t length) const {
    if (offset > size_ || length > size_ - offset)
        return false;
    auto after = slots_.lower_bound(offset);
    if (after != slots_.end() && after->first < offset + length)
        return false;
    if (after != slots_.begin()) {
        const auto before = std::prev(after);
        if (before->first + before->second > offset)
            return false;
    }
    return true;
}

std::optional<std::size_t> ShmRing::allocate(std::size_t length) {
    if (length == 0 || length > size_)
        return std::nullopt;
    const std::size_t padded = (length + alignment - 1) / alignment * alignment;
    if (slots_.empty())
        next_ = 0;  // nothing in use: start again at the front, where the pages are warm
    for (const std::size_t at : {next_, std::size_t{0}}) {
        if (fits(at, length)) {
            slots_.emplace(at, length);
            next_ = at + padded;
            return at;
        }
    }
    return std::nullopt;
}

bool ShmRing::free(std::size_t offset) {
    return slots_.erase(offset) == 1;
}

}  // namespace plexus::detail
