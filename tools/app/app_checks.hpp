#pragma once
// What `plexus check` verifies beyond the schema, without touching the running system: carriers,
// scripts, ports named twice, and the arbitration of every port that several connections feed
// (the daemon's own consistency check and stimulation weights, from plexus_arbitration).

#include <map>
#include <string>
#include <vector>

#include "app_file.hpp"
#include "plexus/proto/carrier.hpp"

namespace plexus::app {

struct CheckReport {
    std::vector<std::string> problems;  ///< the file is bad: check and up exit 2
    std::vector<std::string> warnings;  ///< worth saying, not fatal (a command not found here)
};

/// Every check below, in order.
CheckReport check_app(const App& app);

/// The same connection twice; a component name twice; two components claiming one port.
void check_duplicates(const App& app, CheckReport& report);

/// Each carrier parses and is supported, its arbitration keys are well formed, and every
/// `file.NAME` script exists as NAME.lua in the file's script directories. Returns the parsed
/// carriers of the connections whose carriers are good, by connection index.
std::map<std::size_t, proto::Carrier> check_carriers(const App& app, CheckReport& report);

/// For each destination port with several incoming connections: at most one non-auxiliary
/// connection's constraint true for any assignment of events, and stimulation weights that give
/// a non-singular system for every set of active connections.
void check_arbitration(const App& app, const std::map<std::size_t, proto::Carrier>& carriers,
                       CheckReport& report);

/// Components whose command is not found from here: a warning, since the component may be
/// started on another machine (`up --only-node`); `up` makes it an error for what it starts.
void check_commands(const App& app, CheckReport& report);

}  // namespace plexus::app
