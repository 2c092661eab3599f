#pragma once
// One measured run of one system, and how runs are summarized.

#include <sys/types.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace plexus::bench {

/// Longer than any healthy wait of a measurement; a stall fails the run instead of hanging it.
constexpr std::chrono::seconds stall_timeout{10};

/// Wall-clock nanoseconds: the stamp a message carries from one process (or host) to another.
inline std::uint64_t now_ns() {
    return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                          std::chrono::system_clock::now().time_since_epoch())
                                          .count());
}

/// The figures of one run (or the medians of several).
struct RunResult {
    double p50_us = 0;  ///< latency: round trip / 2; throughput: write call to read return, under load
    double p99_us = 0;
    double mean_us = 0;         ///< the mean of the same samples (calls report it beside p50/p99)
    double msgs_per_s = 0;      ///< messages carried by the broker per second
    double mb_per_s = 0;        ///< payload bytes of those messages, in 10^6 bytes per second
    double cpu_us_per_msg = 0;  ///< CPU time of the broker processes (daemons or relays) per message
    double lost = 0;            ///< fraction of the messages written that never arrived (udp, mcast)
};

/// A prepared scenario on one system (processes started, clients connected); run() measures once.
class Measurement {
public:
    virtual ~Measurement() = default;
    virtual RunResult run() = 0;
};

/// Builds a RunResult: `latencies_us` are per-message samples (sorted here), `messages` the messages
/// the broker carried in `elapsed`, while its processes used `cpu_seconds`.
RunResult summarize(std::vector<double>& latencies_us, std::size_t messages, std::size_t payload_size,
                    std::chrono::steady_clock::duration elapsed, double cpu_seconds);

/// The ping-pong run shared by every system: a warm-up of count/10 (at most 1,000) round trips,
/// then `count` timed ones, with the broker processes' CPU measured around them.
/// `round_trip` returns half a round trip in microseconds.
RunResult time_round_trips(std::size_t count, std::size_t payload_size, const std::vector<pid_t>& broker_pids,
                           const std::function<double()>& round_trip);

/// Nearest-rank percentile (`fraction` in 0..1) of sorted samples; 0 if there are none.
double percentile(const std::vector<double>& sorted, double fraction);
/// The median of some values; 0 if there are none.
double median(std::vector<double> values);

/// The median of each figure over several runs (each figure on its own).
RunResult median_of(const std::vector<RunResult>& runs);

}  // namespace plexus::bench
