#pragma once
// One run of one system in a fresh process of its own. `plexus-bench peers` starts
//     plexus-bench peer-run --system S --scenario X --size N --count C
// which starts the system, runs the scenario through the same run_scenario as every other system
// and prints the figures as one JSON line, then exits; the bench reads that line. For the systems
// whose clients cannot start over inside one process (System::own_process): iceoryx's runtime
// registers with one RouDi for the life of its process, and each run has a RouDi of its own;
// Cyclone DDS's run process enters a network namespace of its own before its domain exists.

#include <cstddef>
#include <string>

#include <nlohmann/json.hpp>

#include "peer_scenarios.hpp"
#include "pubsub.hpp"

namespace plexus::bench::peers {

/// The arguments of `plexus-bench peer-run`.
struct PeerRunOptions {
    std::string system;
    std::string scenario;
    std::size_t size = 64;
    std::size_t count = 100;
    std::string plexusd;
};

/// Runs `scenario` on `system` in a `peer-run` process (setup.self) and returns its figures;
/// throws with the process's last output if it printed none.
PeerResult run_in_own_process(const System& system, Scenario scenario, const Workload& workload,
                              const BrokerSetup& setup);

/// A run's figures as the JSON keys every row of `peers --json` has (p50_us ... rss_mb, warning).
nlohmann::json to_json(const PeerResult& result);

/// Body of `plexus-bench peer-run`: prints the figures of one run as JSON; returns the exit status.
int run_peer_run(const PeerRunOptions& options);

}  // namespace plexus::bench::peers
