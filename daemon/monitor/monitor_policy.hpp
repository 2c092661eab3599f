#pragma once
// The limits every port monitor of a daemon runs under, apart from the monitors themselves: the
// daemon's configuration (daemon_config.hpp) holds them without seeing Lua.

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
};

}  // namespace plexus::daemon::monitor
