#pragma once
// Threading: any; loading happens on the daemon's thread when a connection is made.
//
// A compiled monitor's shared library: dlopen'ed from a path script_library's find_plugin gave (so
// only from a --monitor-libs directory), its entry symbol resolved and its ABI version checked.
// Each monitor holds its library; the library is closed when the last monitor using it goes.

#include <memory>
#include <string>

#include "plexus/monitor_plugin.h"
#include "plexus/proto/bytes.hpp"

namespace plexus::daemon::monitor {

class PluginLibrary {
public:
    /// Loads `path` (RTLD_NOW | RTLD_LOCAL: every symbol resolved now, none leaking into other
    /// plugins) and checks its descriptor. Errors name the plugin, the path and the reason: the
    /// loader's message, a missing `plexus_monitor_entry`, or an ABI version other than ours.
    static proto::Result<std::shared_ptr<PluginLibrary>> load(const std::string& name,
                                                              const std::string& path);
    ~PluginLibrary();
    PluginLibrary(const PluginLibrary&) = delete;
    PluginLibrary& operator=(const PluginLibrary&) = delete;

    const plexus_monitor_plugin& plugin() const { return *plugin_; }

private:
    PluginLibrary(void* handle, const plexus_monitor_plugin* plugin) : handle_(handle), plugin_(plugin) {}

    void* handle_;
    const plexus_monitor_plugin* plugin_;
};

}  // namespace plexus::daemon::monitor
