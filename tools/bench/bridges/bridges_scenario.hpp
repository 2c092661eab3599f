#pragma once
// `plexus-bench bridges` (docs/BENCHMARKS.md, "Bridges"): what plexus-bridge adds to a path between
// two programs of another system, against the same path without it, in the same run, alternated.
//   DDS:  pinger -> rt/bench/ping -> [bridge -> plexusd -> bridge ->] echo -> rt/bench/pong -> pinger
//   MQTT: pinger -> bench/ping -> mosquitto -> [bridge -> plexusd -> bridge -> mosquitto ->] echo -> ...
// The direct path has the same shape with the echo reading the pinger's topic itself. Everything runs
// in a network namespace of the bench's own (DDS discovers by multicast there, never on this
// machine's interfaces); needs root.
#include <cstddef>
#include <string>
#include <vector>

namespace plexus::bench::bridges {

struct BridgesOptions {
    std::string plexusd;
    std::string bridge;  ///< plexus-bridge
    std::string plexus;  ///< the CLI (connects the bridge's ports)
    std::string mosquitto = "/usr/sbin/mosquitto";
    std::vector<std::size_t> sizes{64, 1 << 20};
    std::vector<std::string> links{"dds", "mqtt"};
    int repeat = 3;
    bool quick = false;
    bool json = false;
};

int run_bridges(const BridgesOptions& options);

}  // namespace plexus::bench::bridges
