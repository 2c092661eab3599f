#pragma once
// Threading: as its Monitor's (one thread at a time).
//
// A monitor written in Lua: the script in its own sandboxed state, the `msg` object, and the
// PortMonitor functions bound to the Monitor shell.

#include <memory>

#include "monitor.hpp"
#include "monitor_backend.hpp"

namespace plexus::daemon::monitor {

/// Loads `monitor.spec().script` and calls its create(options). Errors name the script and, for
/// Lua errors, its file and line.
proto::Result<std::unique_ptr<MonitorBackend>> make_lua_monitor(Monitor& monitor,
                                                                const MonitorPolicy& policy);

}  // namespace plexus::daemon::monitor
