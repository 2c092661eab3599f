#include "heap_trimmer.hpp"

#include <malloc.h>

#include <algorithm>

#include <spdlog/spdlog.h>

namespace plexus::daemon {

void HeapTrimmer::start() {
    asio::co_spawn(io_, loop(), asio::detached);
}

bool HeapTrimmer::trim_if_drained() {
    // mallinfo2 sums every arena (the monitor workers' too); fordblks is what is free inside them.
    const struct mallinfo2 heap = ::mallinfo2();
    const std::size_t free_bytes = heap.fordblks;
    const std::size_t used_bytes = heap.uordblks;
    // Free memory that was reused since (a new burst) lowers the mark the next trim is measured from.
    free_after_last_trim_ = std::min(free_after_last_trim_, free_bytes);
    // Pages given back stay counted as free (malloc_trim only advises the kernel to drop them): so
    // only free memory that grew since the last trim is worth another one.
    if (free_bytes < free_after_last_trim_ + settings_.least_free_bytes || free_bytes < used_bytes)
        return false;
    ::malloc_trim(0);
    ++trims_;
    const struct mallinfo2 after = ::mallinfo2();
    free_after_last_trim_ = after.fordblks;
    spdlog::debug("heap: {} MiB free of {} MiB in use gave back to the kernel ({} MiB left free)",
                  free_bytes >> 20, used_bytes >> 20, after.fordblks >> 20);
    return true;
}

Task<void> HeapTrimmer::loop() {
    asio::steady_timer timer(io_);
    while (!stopped_) {
        timer.expires_after(settings_.period);
        auto [ec] = co_await timer.async_wait(use_nothrow);
        if (ec || stopped_)
            co_return;
        trim_if_drained();
    }
}

}  // namespace plexus::daemon
