#pragma once
// The counters of one connection into a port, as `plexus stats` and `plexus events` show them.

#include <nlohmann/json.hpp>

#include "core/inlet.hpp"

namespace plexus::daemon {

/// received, accepted, dropped_by_accept / constraint / priority / queue, delivered, script_errors.
inline nlohmann::json inlet_counters(const Inlet& inlet) {
    nlohmann::json counters = {{"received", inlet.received},
                               {"accepted", inlet.accepted},
                               {"dropped_by_accept", inlet.dropped_by_accept},
                               {"dropped_by_constraint", inlet.member().dropped_by_constraint},
                               {"dropped_by_priority", inlet.member().dropped_by_priority},
                               {"dropped_by_queue", inlet.dropped_by_queue},
                               {"delivered", inlet.delivered},
                               {"script_errors", inlet.script_errors()}};
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
