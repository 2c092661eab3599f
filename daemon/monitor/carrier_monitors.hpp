#pragma once
// Threading: the caller's; the monitors it makes belong to that thread until handed to a stage.
//
// The monitors a carrier string asks for on one side of a connection, built in carrier order.
// One definition for the daemon (ScriptHost) and for `plexus what-if`, which re-runs a recorded
// port's monitors offline and must build exactly what the daemon built.

#include <memory>
#include <string>
#include <vector>

#include "chain.hpp"
#include "monitor.hpp"
#include "plexus/proto/carrier.hpp"

namespace plexus::daemon::monitor {

/// Where the monitors' code is found and the limits they run under.
struct ChainPlaces {
    const std::vector<std::string>& script_dirs;
    const std::vector<std::string>& monitor_lib_dirs;
    const MonitorPolicy& policy;
};

/// The MonitorSpec of one portmonitor clause: the keys the monitor takes for itself, the rest for
/// the script's create(options). The script itself is not looked for yet.
proto::Result<MonitorSpec> spec_of_clause(const proto::Clause& clause, const proto::Carrier& carrier,
                                          const std::string& source, const std::string& destination);

/// The monitors of `side` of the connection `source` -> `destination`. Fails (and creates nothing)
/// when a script is missing, does not load, or refuses; null when the side has none. Recv-side
/// monitors take part in the arbitration through `member`.
proto::Result<std::shared_ptr<MonitorChain>> build_carrier_chain(
    const proto::Carrier& carrier, proto::Side side, const std::string& source,
    const std::string& destination, const std::shared_ptr<arbitration::Member>& member,
    const ChainPlaces& places, MonitorHost& host);

}  // namespace plexus::daemon::monitor
