#pragma once
// Threading: as its Monitor's (one thread at a time).
//
// A compiled monitor: a plugin library's callbacks, called with the message as a view (one
// indirect call per callback, no decoding, no allocation on accept), every error and exception
// turned into a ScriptError that the Monitor shell counts like a script's.

#include <memory>

#include "monitor.hpp"
#include "monitor_backend.hpp"

namespace plexus::daemon::monitor {

/// Loads `monitor.spec().script.path` and calls the plugin's create with the clause's options.
/// Errors name the plugin and the reason (load, entry symbol, ABI version, create's refusal).
proto::Result<std::unique_ptr<MonitorBackend>> make_plugin_monitor(Monitor& monitor);

}  // namespace plexus::daemon::monitor
