#include "measurement.hpp"

#include "process_stats.hpp"

#include <algorithm>
#include <functional>
#include <numeric>
#include <stdexcept>

namespace plexus::bench {

double percentile(const std::vector<double>& sorted, double fraction) {
    if (sorted.empty())
        return 0;
    const auto rank = static_cast<std::size_t>(fraction * static_cast<double>(sorted.size()) + 0.999999);
    return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

double median(std::vector<double> values) {
    if (values.empty())
        return 0;
    std::sort(values.begin(), values.end());
    const std::size_t middle = values.size() / 2;
    return values.size() % 2 == 1 ? values[middle] : (values[middle - 1] + values[middle]) / 2;
}

RunResult summarize(std::vector<double>& latencies_us, std::size_t messages, std::size_t payload_size,
                    std::chrono::steady_clock::duration elapsed, double cpu_seconds) {
    std::sort(latencies_us.begin(), latencies_us.end());
    const double seconds = std::chrono::duration<double>(elapsed).count();
    if (seconds <= 0 || messages == 0)
        throw std::runtime_error("a run measured nothing");
    RunResult result;
    result.p50_us = percentile(latencies_us, 0.50);
    result.p99_us = percentile(latencies_us, 0.99);
    result.mean_us = latencies_us.empty() ? 0
                                          : std::accumulate(latencies_us.begin(), latencies_us.end(), 0.0) /
                                                static_cast<double>(latencies_us.size());
    result.msgs_per_s = static_cast<double>(messages) / seconds;
    result.mb_per_s = result.msgs_per_s * static_cast<double>(payload_size) / 1e6;
    result.cpu_us_per_msg = cpu_seconds * 1e6 / static_cast<double>(messages);
    return result;
}

RunResult median_of(const std::vector<RunResult>& runs) {
    auto figure = [&](double RunResult::*member) {
        std::vector<double> values;
        for (const auto& run : runs)
            values.push_back(run.*member);
        return median(std::move(values));
    };
    return {figure(&RunResult::p50_us),     figure(&RunResult::p99_us),   figure(&RunResult::mean_us),
            figure(&RunResult::msgs_per_s), figure(&RunResult::mb_per_s), figure(&RunResult::cpu_us_per_msg),
            figure(&RunResult::lost)};
}

RunResult time_round_trips(std::size_t count, std::size_t payload_size, const std::vector<pid_t>& broker_pids,
                           const std::function<double()>& round_trip) {
    for (std::size_t i = 0; i < std::min<std::size_t>(count / 10 + 1, 1000); ++i)
        round_trip();
    std::vector<double> samples;
    samples.reserve(count);
    const double cpu_before = cpu_seconds(broker_pids);
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < count; ++i)
        samples.push_back(round_trip());
    const auto elapsed = std::chrono::steady_clock::now() - start;
    const double cpu = cpu_seconds(broker_pids) - cpu_before;
    return summarize(samples, 2 * count, payload_size, elapsed, cpu);
}

}  // namespace plexus::bench
