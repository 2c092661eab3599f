#pragma once
// Threading: the daemon's one thread; takes the port's arbiter lock itself (its monitors may be
// changing the arbitration on their workers meanwhile).
//
// `plexus events PORT`: the port's event container, the constraints and stimulation of the
// connections into it, and their counters. A view of its own, apart from the control plane.

#include <string>

#include <nlohmann/json.hpp>

#include "core/port.hpp"

namespace plexus::daemon::inspect {

/// The arbitration state of `port` (hosted by node `node`) at time `now` on the arbitration clock;
/// `check` adds the overlapping pairs of constraints with their witnesses.
nlohmann::json events_view(const Port& port, bool check, const std::string& node, double now);

}  // namespace plexus::daemon::inspect
