#pragma once
// The limits every port monitor of a daemon runs under, apart from the monitors themselves: the
// daemon's configuration (app/daemon_config.hpp) holds them without seeing Lua.

#include <chrono>
#include <cstddef>
#include <cstdint>

namespace plexus::daemon::monitor {

struct SandboxLimits {
    std::size_t memory_bytes = 16u * 1024u * 1024u;
    std::chrono::milliseconds budget{20};  ///< per call into the script
};

struct MonitorPolicy {
    SandboxLimits limits;
    std::uint32_t quarantine_after = 5;  ///< consecutive failed calls
    /// Monitors costing less than this per message run inline on the daemon's thread
    /// (monitor/stage.hpp); zero: always on workers.
    std::chrono::microseconds inline_cost_limit{10};
};

}  // namespace plexus::daemon::monitor
