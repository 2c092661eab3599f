#pragma once
// Threading: a pure function.

#include <chrono>

namespace plexus::daemon {

/// Seconds since the Unix epoch, as the web views stamp what they show (docs/WEB.md, "t"): a
/// browser compares them with its own clock, so they are wall-clock time, not the steady clock
/// arbitration runs on.
inline double wall_seconds() {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace plexus::daemon
