#pragma once
// Threading: the daemon's one thread (it reads the router, the sessions' and the daemon's counters).
//
// `plexus stats`: every port of this daemon (or one), its queue, its connections out and in, and
// the daemon-wide counters. A view of its own, apart from the control plane's request handling,
// so that whatever else shows the daemon (the control op today) builds the same JSON.

#include <string>

#include <nlohmann/json.hpp>

#include "control/control_host.hpp"
#include "net/shm_region.hpp"

namespace plexus::daemon::inspect {

/// The stats of every port of `host` (only `only_port`'s when not empty) and its daemon-wide
/// counters, `shm` being the shared-memory regions handed out so far.
nlohmann::json stats_view(ControlHost& host, const ShmUsage& shm, const std::string& only_port);

}  // namespace plexus::daemon::inspect
