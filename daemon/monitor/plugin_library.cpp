#include "plugin_library.hpp"

#include <dlfcn.h>

#include <exception>

namespace plexus::daemon::monitor {

namespace {

std::string loader_error() {
    const char* text = ::dlerror();
    return text ? text : "unknown loader error";
}

}  // namespace

proto::Result<std::shared_ptr<PluginLibrary>> PluginLibrary::load(const std::string& name,
                                                                  const std::string& path) {
    const std::string which = "monitor plugin '" + name + "' (" + path + ")";
    // A path with a slash: dlopen opens that file and never searches LD_LIBRARY_PATH or the system.
    if (path.find('/') == std::string::npos)
        return proto::Error{which + ": not a path to a file"};
    ::dlerror();
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle)
        return proto::Error{which + " failed to load: " + loader_error()};
    // From here the handle is closed on every failure.
    std::unique_ptr<void, int (*)(void*)> closer(handle, &::dlclose);
    ::dlerror();
    void* symbol = ::dlsym(handle, PLEXUS_MONITOR_ENTRY_SYMBOL);
    if (!symbol)
        return proto::Error{which +
                            " has no " PLEXUS_MONITOR_ENTRY_SYMBOL " symbol: not a Plexus monitor plugin (" +
                            loader_error() + ")"};
    const auto entry = reinterpret_cast<plexus_monitor_entry_fn>(symbol);
    const plexus_monitor_plugin* plugin = nullptr;
    try {
        plugin = entry();
    } catch (const std::exception& e) {
        return proto::Error{which + ": " PLEXUS_MONITOR_ENTRY_SYMBOL " threw: " + e.what()};
    } catch (...) {
        return proto::Error{which + ": " PLEXUS_MONITOR_ENTRY_SYMBOL " threw"};
    }
    if (!plugin)
        return proto::Error{which + ": " PLEXUS_MONITOR_ENTRY_SYMBOL " returned no descriptor"};
    if (plugin->abi_version != PLEXUS_MONITOR_ABI_VERSION)
        return proto::Error{which + " was built for monitor ABI version " +
                            std::to_string(plugin->abi_version) + ", this plexusd speaks version " +
                            std::to_string(PLEXUS_MONITOR_ABI_VERSION) +
                            ": rebuild it against this plexusd's plexus/monitor_plugin.h"};
    return std::shared_ptr<PluginLibrary>(new PluginLibrary(closer.release(), plugin));
}

PluginLibrary::~PluginLibrary() {
    ::dlclose(handle_);
}

}  // namespace plexus::daemon::monitor
