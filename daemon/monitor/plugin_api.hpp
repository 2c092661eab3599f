#pragma once
// Threading: as its Monitor's (one thread at a time).
//
// The host side of the plugin ABI: the plexus_host a plugin passes back to every host function,
// and the table of those functions (plexus_host_api). They call the Monitor shell's PortMonitor
// functions, so a plugin gets the same checks and errors as a script, and they never let a C++
// exception out into the plugin's C frames.

#include <string>

#include "monitor.hpp"
#include "plexus/monitor_plugin.h"

/// One plugin monitor's side of the daemon.
struct plexus_host {
    plexus::daemon::monitor::Monitor* monitor = nullptr;
    std::string error;       ///< what the plugin gave with set_error during the current callback
    std::string last_error;  ///< why the last host function failed
    std::string constraint;  ///< get_constraint's answer, kept until the next call
};

namespace plexus::daemon::monitor {

/// The one table every plugin gets.
const plexus_host_api& plugin_host_api();

}  // namespace plexus::daemon::monitor
