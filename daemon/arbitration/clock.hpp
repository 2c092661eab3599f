#pragma once
// Threading: the daemon's one thread.

#include <chrono>

namespace plexus::daemon::arbitration {

/// Where arbitration reads the time: event lifetimes and stimulation decay. The daemon uses the
/// steady clock; tests use a clock they move by hand.
class Clock {
public:
    virtual ~Clock() = default;
    /// Seconds from an arbitrary fixed origin; never goes backwards.
    virtual double now() const = 0;
};

class SteadyClock final : public Clock {
public:
    double now() const override {
        return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
    }
};

/// A clock a test sets by hand.
class ManualClock final : public Clock {
public:
    double now() const override { return now_; }
    void set(double seconds) { now_ = seconds; }
    void advance(double seconds) { now_ += seconds; }

private:
    double now_ = 1000.0;
};

}  // namespace plexus::daemon::arbitration
