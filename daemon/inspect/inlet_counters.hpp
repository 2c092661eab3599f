#pragma once
// The counters of one connection into a port, as `plexus stats` and `plexus events` show them.

#include <mutex>

#include <nlohmann/json.hpp>

#include "core/inlet.hpp"
#include "monitor/stage.hpp"

namespace plexus::daemon {

/// received, accepted, dropped_by_accept / constraint / priority / queue, delivered, script_errors.
/// Takes the arbiter's lock: call it without holding it.
inline nlohmann::json inlet_counters(const Inlet& inlet) {
    std::uint64_t by_constraint = 0;
    std::uint64_t by_priority = 0;
    {
        std::lock_guard lock(inlet.member().arbiter().mutex());
        by_constraint = inlet.member().dropped_by_constraint;
        by_priority = inlet.member().dropped_by_priority;
    }
    std::uint64_t script_errors = 0;
    if (const auto* stage = monitor::stage_of(inlet.monitors)) {
        for (const auto& monitor : stage->chain().monitors)
            script_errors += monitor->counters().errors;
    }
    nlohmann::json counters = {{"received", inlet.received},
                               {"accepted", inlet.accepted},
                               {"dropped_by_accept", inlet.dropped_by_accept},
                               {"dropped_by_constraint", by_constraint},
                               {"dropped_by_priority", by_priority},
                               {"dropped_by_queue", inlet.dropped_by_queue},
                               {"delivered", inlet.delivered},
                               {"script_errors", script_errors}};
    if (inlet.datagrams) {
        // udp/mcast: what the datagram stream lost on the way (DESIGN, "Several machines").
        const auto& stream = inlet.datagrams->counters();
        counters["lost"] = stream.lost;
        counters["late"] = stream.late;
        counters["incomplete"] = stream.incomplete;
        counters["dropped_full"] = inlet.dropped_full;
    }
    return counters;
}

}  // namespace plexus::daemon
