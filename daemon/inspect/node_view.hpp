#pragma once
// Threading: the daemon's one thread (as stats_view and events_view, which it is made of).
//
// One daemon's part of the whole system's view (docs/WEB.md, `/api/system`): its stats and the
// arbitration of every port with connections in. The web endpoint builds it for its own daemon,
// and asks the other daemons for theirs with the `inspect` op, which answers with the same.

#include <nlohmann/json.hpp>

#include "control/control_host.hpp"
#include "net/shm_region.hpp"

namespace plexus::daemon::inspect {

/// `{"node", "address", "stats": STATS, "arbitration": [EVENTS...]}`.
nlohmann::json node_view(ControlHost& host, const ShmUsage& shm);
/// `{"node", "arbitration": [EVENTS...]}`: the part the live stream sends 20 times a second.
nlohmann::json arbitration_view(ControlHost& host);

}  // namespace plexus::daemon::inspect
