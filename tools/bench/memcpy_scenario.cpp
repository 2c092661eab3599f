// plexus-bench memcpy: how fast this machine copies a payload in memory, the yardstick for "large
// messages at memory-bandwidth speed". A message through shared memory is copied twice (by the
// writer into its region, by each reader out of it), so one copy's rate is an upper bound for a
// stream and half of it a fair floor to compare with.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <vector>

#include "measurement.hpp"
#include "scenarios.hpp"

namespace plexus::bench {

namespace {

using Clock = std::chrono::steady_clock;

/// GB/s (10^9 bytes) of `copies` copies of `size` bytes, cycling through `slots` source and
/// destination buffers: one slot keeps everything in the cache, many make each copy go to memory.
double copy_rate(std::size_t size, std::size_t slots, std::size_t copies) {
    std::vector<std::vector<unsigned char>> from(slots, std::vector<unsigned char>(size, 0x5a));
    std::vector<std::vector<unsigned char>> to(slots, std::vector<unsigned char>(size, 0));
    for (std::size_t i = 0; i < slots; ++i)  // warm-up: pages faulted in, caches as in the loop
        std::memcpy(to[i].data(), from[i].data(), size);
    const auto start = Clock::now();
    for (std::size_t i = 0; i < copies; ++i)
        std::memcpy(to[i % slots].data(), from[(i * 7 + 3) % slots].data(), size);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    volatile unsigned char sink = to[copies % slots][size / 2];  // the copies are not optimised away
    (void)sink;
    return static_cast<double>(size) * static_cast<double>(copies) / seconds / 1e9;
}

}  // namespace

int run_memcpy(const Options& options) {
    const std::size_t size = std::max<std::size_t>(options.size, 64);
    // 64 MiB of sources and as much of destinations: far beyond any last-level cache here.
    const std::size_t cold_slots = std::max<std::size_t>(2, (std::size_t{64} << 20) / size);
    const std::size_t copies = std::max<std::size_t>(64, (std::size_t{2} << 30) / size);
    std::vector<double> warm;
    std::vector<double> cold;
    for (int run = 0; run < options.repeat; ++run) {
        warm.push_back(copy_rate(size, 1, copies));
        cold.push_back(copy_rate(size, cold_slots, copies));
    }
    if (options.json) {
        std::printf("{\"scenario\":\"memcpy\",\"size\":%zu,\"warm_gb_per_s\":%.2f,\"cold_gb_per_s\":%.2f}\n",
                    size, median(warm), median(cold));
        return 0;
    }
    std::printf("memcpy, %zu B per copy, one thread: median of %d runs of %zu copies\n", size, options.repeat,
                copies);
    std::printf("  warm (one buffer pair, in cache)        %8.2f GB/s\n", median(warm));
    std::printf("  cold (64 MiB of buffers each way)       %8.2f GB/s\n", median(cold));
    std::printf("  cold / 2 (a message copied twice)       %8.2f GB/s\n", median(cold) / 2);
    return 0;
}

}  // namespace plexus::bench
