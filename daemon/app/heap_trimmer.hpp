#pragma once
// Threading: one io_context thread (a timer loop on the daemon's thread).

#include <chrono>
#include <cstddef>
#include <cstdint>

#include "net/asio.hpp"

namespace plexus::daemon {

/// Gives memory that a drained burst left in the heap back to the kernel.
///
/// plexusd keeps freed memory in the heap while frames come and go (main_plexusd.cpp raises glibc's
/// trim threshold: returning and faulting pages back in at every large frame costs throughput).
/// Without this, a daemon whose queues once held 200 MiB kept them for good. Once a second it asks
/// glibc how much of the heap is free; when that is both large and more than what is in use (the
/// queues have drained), it calls malloc_trim, which also returns free pages inside the heap.
class HeapTrimmer {
public:
    struct Settings {
        std::chrono::milliseconds period{1000};
        std::size_t least_free_bytes = 16u * 1024u * 1024u;  ///< below this, nothing is worth a trim
    };

    HeapTrimmer(asio::io_context& io, Settings settings) : io_(io), settings_(settings) {}
    /// Starts the timer loop; it ends when stop() is called or the io_context stops.
    void start();
    void stop() { stopped_ = true; }
    /// Trims now if the heap holds enough free memory; true if it trimmed.
    bool trim_if_drained();
    std::uint64_t trims() const { return trims_; }

private:
    Task<void> loop();

    asio::io_context& io_;
    Settings settings_;
    std::uint64_t trims_ = 0;
    std::size_t free_after_last_trim_ = 0;
    bool stopped_ = false;
};

}  // namespace plexus::daemon
