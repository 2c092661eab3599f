// A plugin built for an ABI version this daemon does not speak: loading it must fail, naming both.
#include <plexus/monitor_plugin.h>

namespace {
const plexus_monitor_plugin descriptor = {PLEXUS_MONITOR_ABI_VERSION + 998,
                                          "wrong_abi",
                                          nullptr,
                                          nullptr,
                                          nullptr,
                                          nullptr,
                                          nullptr,
                                          nullptr,
                                          nullptr};
}  // namespace

extern "C" PLEXUS_MONITOR_EXPORT const plexus_monitor_plugin* plexus_monitor_entry(void) {
    return &descriptor;
}
