#pragma once
// Threading: a value; each one has one owning thread.
//
// Observed durations in fixed buckets, as Prometheus histograms count them (cumulative on output),
// so `/metrics` can show a distribution and not only a moving average.

#include <array>
#include <cstdint>

#include <nlohmann/json.hpp>

namespace plexus::daemon {

class LatencyHistogram {
public:
    /// Upper bounds in seconds: 1 us to 10 ms (a monitor's cost per message; the inline limit is
    /// 10 us, a Lua script's usual cost 1-20 us), then +Inf.
    static constexpr std::array<double, 10> bounds{1e-6, 2.5e-6, 5e-6,   1e-5, 2.5e-5,
                                                   5e-5, 1e-4,   2.5e-4, 1e-3, 1e-2};

    /// Counts `times` observations of `seconds` each (a batch's messages share its average cost).
    void observe(double seconds, std::uint64_t times = 1) {
        std::size_t i = 0;
        while (i < bounds.size() && seconds > bounds[i])
            ++i;
        counts_[i] += times;
        count_ += times;
        sum_ += seconds * static_cast<double>(times);
    }
    /// `{"le": [bounds...], "counts": [per bucket, not cumulative, the last for +Inf], "sum", "count"}`.
    nlohmann::json to_json() const {
        return {{"le", bounds}, {"counts", counts_}, {"sum", sum_}, {"count", count_}};
    }

private:
    std::array<std::uint64_t, bounds.size() + 1> counts_{};
    std::uint64_t count_ = 0;
    double sum_ = 0;
};

}  // namespace plexus::daemon
