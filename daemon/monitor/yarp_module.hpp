#pragma once
// Threading: works on one Lua state, from whichever thread runs that state's monitor.
//
// `require("yarp")` for scripts written for YARP, whose first line it is. The sandbox has no
// modules, so `require` takes that one name and nothing else. What the module gives is what
// Plexus can honestly serve: `yarp.Time_now()` (the monitor's clock, PortMonitor.now()) and
// `yarp.log(...)` (the daemon log, like print). Any other name (yarp.Bottle, yarp.Time_delay,
// yarp.Network, ...) is a function that does nothing, returns nil, and logs a warning the first
// time each name is called, so a script that only touches them in passing still runs.

#include <lua.hpp>

namespace plexus::daemon::monitor {

/// Installs the global `require` that answers "yarp" with the module above and refuses anything
/// else with an error that says so.
void open_yarp_require(lua_State* L);

}  // namespace plexus::daemon::monitor
