// A plugin whose accept throws a C++ exception on every message: the daemon must contain it,
// count it like a script error, and go on.
#include <plexus/monitor_plugin.h>

#include <stdexcept>
#include <string>

namespace {

int accept(void*, const plexus_message* message) {
    throw std::runtime_error("plugin exploded on message " + std::to_string(message->seq));
}

const plexus_monitor_plugin descriptor = {
    PLEXUS_MONITOR_ABI_VERSION, "throwing", nullptr, accept, nullptr, nullptr, nullptr, nullptr, nullptr};

}  // namespace

extern "C" PLEXUS_MONITOR_EXPORT const plexus_monitor_plugin* plexus_monitor_entry(void) {
    return &descriptor;
}
