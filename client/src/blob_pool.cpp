#include "blob_pool.hpp"

#include <deque>
#include <mutex>

#include "large_payload.hpp"
#include "plexus/client.hpp"

namespace plexus::detail {

namespace {

// A reader that keeps the previous message while reading the next (Python's `m = port.read()`
// in a loop) cycles through two buffers, plus those of the messages received but not read yet:
// a shared-memory region holds about four payloads (daemon/control/ports.cpp), so up to four more
// arrive in one go.
constexpr std::size_t kept_buffers = 8;
constexpr std::size_t kept_bytes = 64u << 20;

struct Pool {
    std::mutex mutex;
    std::deque<std::vector<std::uint8_t>> buffers;  ///< oldest first
    std::size_t bytes = 0;                          ///< their capacities, summed
};

Pool& pool() {
    // Never destroyed: a buffer may be handed back while the process exits (a Python array freed
    // late), after static destructors would have run.
    static auto* the_pool = new Pool;
    return *the_pool;
}

}  // namespace

std::vector<std::uint8_t> take_blob_buffer(std::size_t size) {
    if (size >= large_payload_frame) {
        Pool& p = pool();
        std::lock_guard lock(p.mutex);
        // The smallest buffer that fits, so that a large one stays for a large blob.
        auto best = p.buffers.end();
        for (auto it = p.buffers.begin(); it != p.buffers.end(); ++it) {
            if (it->capacity() >= size && it->capacity() / 4 <= size &&
                (best == p.buffers.end() || it->capacity() < best->capacity()))
                best = it;
        }
        if (best != p.buffers.end()) {
            std::vector<std::uint8_t> found = std::move(*best);
            p.buffers.erase(best);
            p.bytes -= found.capacity();
            found.clear();
            return found;
        }
    }
    std::vector<std::uint8_t> fresh;
    fresh.reserve(size);
    return fresh;
}

void keep_blob_buffer(std::vector<std::uint8_t>&& bytes) {
    const std::size_t capacity = bytes.capacity();
    if (capacity < large_payload_frame || capacity > kept_bytes)
        return;                                     // freed by the caller's vector as usual
    std::deque<std::vector<std::uint8_t>> dropped;  // freed after the lock is let go
    Pool& p = pool();
    std::lock_guard lock(p.mutex);
    p.buffers.push_back(std::move(bytes));
    p.bytes += capacity;
    while (p.buffers.size() > kept_buffers || p.bytes > kept_bytes) {
        p.bytes -= p.buffers.front().capacity();
        dropped.push_back(std::move(p.buffers.front()));
        p.buffers.pop_front();
    }
}

}  // namespace plexus::detail

namespace plexus {

void recycle_blob(std::vector<std::uint8_t>&& bytes) {
    detail::keep_blob_buffer(std::move(bytes));
}

}  // namespace plexus
