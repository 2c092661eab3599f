#pragma once
// How many times slower than the release build this build runs: PLEXUS_TEST_SLOWDOWN (default 1;
// scripts/sanitize sets it for the sanitized builds, docs/SANITIZERS.md). Read here only, once.
// Stretches bounds about speed (deadlines, latencies, memory growth that a sanitizer's shadow
// memory inflates), never a bound about correctness (counts, order, contents, losses).

#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace plexus::test {

inline double slowdown() {
    static const double factor = [] {
        const char* text = std::getenv("PLEXUS_TEST_SLOWDOWN");
        if (!text || !*text)
            return 1.0;
        char* end = nullptr;
        const double value = std::strtod(text, &end);
        if (*end != '\0' || !(value >= 1.0) || value > 100.0) {
            std::fprintf(stderr, "PLEXUS_TEST_SLOWDOWN=%s: not a factor from 1 to 100\n", text);
            std::abort();
        }
        return value;
    }();
    return factor;
}

/// A speed bound stretched by slowdown().
template <typename Rep, typename Period>
std::chrono::duration<Rep, Period> slower(std::chrono::duration<Rep, Period> bound) {
    return std::chrono::duration<Rep, Period>(
        static_cast<Rep>(static_cast<double>(bound.count()) * slowdown()));
}

}  // namespace plexus::test
