#pragma once
// Threading: pure functions.
//
// `/metrics`: the daemon's `plexus stats` document in the Prometheus text format (0.0.4). Made
// from the same document, so the two always agree: every number of stats is a metric named
// `plexus_<part>_<field>_total` (a counter) or `plexus_<part>_<field>` (a gauge: queue depths,
// bytes held, sessions), labelled with node, port and source or destination.

#include <string>

#include <nlohmann/json.hpp>

#include "http_counters.hpp"

namespace plexus::daemon::web {

/// The metrics of a `stats` document (this daemon's) and of the web endpoint's own counters.
std::string metrics_text(const nlohmann::json& stats, const HttpCounters& http);

}  // namespace plexus::daemon::web
