// A shared library that is not a monitor plugin: no plexus_monitor_entry.
#include <plexus/monitor_plugin.h>

extern "C" PLEXUS_MONITOR_EXPORT int plexus_something_else(void) {
    return 42;
}
