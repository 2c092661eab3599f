#pragma once
// What the parts of `plexus-bench hosts` share: the deployments (plexus-names and plexusd on the
// hosts), the relay floor across two hosts, and running several systems in turn into one row.
//
// Threading: used from the bench's main thread only.

#include <sys/types.h>

#include <cstddef>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "child_process.hpp"
#include "hosts_network.hpp"
#include "hosts_scenario.hpp"
#include "measurement.hpp"
#include "options.hpp"
#include "topology.hpp"

namespace plexus::bench {

/// start_when_ready for a wrapped argv (`ip netns exec NS PROGRAM ...`): its 4th and 5th words
/// say what and where.
std::string start_ready(std::vector<std::unique_ptr<ChildProcess>>& processes,
                        const std::vector<std::string>& argv, const std::string& ready_file,
                        const std::string& log);

/// plexus-names on host 0 and plexusd on some hosts, with or without the deployment secret.
class Deployment {
public:
    /// `secret_file` "": --insecure. Names, groups and ports differ per deployment so that two can
    /// share hosts. `identities` (with a secret): the name server and every daemon get an identity
    /// of a CA made in `dir` (mutual TLS with certificates), and every daemon a permissions file
    /// whose rules allow what the bench does, so that each check is made.
    Deployment(const HostsNetwork& network, const TempDir& dir, const HostsOptions& options,
               const std::string& tag, const std::string& secret_file, const std::vector<int>& hosts,
               int names_port, const std::string& mcast_range, int mcast_port, bool identities = false);

    /// The daemons of hosts a and b as a Topology for plexus_measurements.hpp (a near, b far).
    std::unique_ptr<Topology> pair(int a, int b) const {
        return Topology::existing({sockets_.at(a), sockets_.at(b)}, {pids_.at(a), pids_.at(b)});
    }
    /// The Unix socket of host k's daemon.
    const std::string& socket(int k) const { return sockets_.at(k); }

private:
    std::string start(const std::vector<std::string>& argv, const std::string& ready_file,
                      const std::string& log) {
        return start_ready(processes_, argv, ready_file, log);
    }

    std::vector<std::unique_ptr<ChildProcess>> processes_;
    std::string names_;
    std::map<int, std::string> sockets_;
    std::map<int, pid_t> pids_;
};

/// The relay floor across hosts: relay.cpp's two relays linked by tcp, one on host a and one on
/// host b, with the clients on Unix sockets: the same processes and socket hops as Plexus, less
/// everything Plexus does beyond forwarding frames. One per measurement (a relay pairs one client).
class RelayPair {
public:
    /// `udp`: the relays exchange frames as datagrams (the udp carrier's floor; latency only).
    RelayPair(const HostsNetwork& network, const TempDir& dir, const std::string& tag, int a, int b,
              bool udp = false);
    /// The relays as a Topology (a near, b far).
    const Topology& topology() const { return *topology_; }

private:
    std::vector<std::unique_ptr<ChildProcess>> processes_;
    std::unique_ptr<Topology> topology_;
};

/// Writes a fresh deployment secret (32 hex digits, mode 0600) into `dir`; returns its path.
std::string write_secret(const TempDir& dir);

/// One scenario on several systems, medians of each.
struct Row {
    std::string scenario;  ///< "latency", "throughput", "calls"
    std::string carrier;
    std::size_t size = 0;
    std::size_t count = 0;
    std::vector<std::pair<std::string, RunResult>> systems;  ///< "plexus", "floor", "plexus_insecure"

    /// The medians of `system`; nullptr if it was not run.
    const RunResult* find(const std::string& system) const {
        for (const auto& [name, result] : systems) {
            if (name == system)
                return &result;
        }
        return nullptr;
    }
};

/// Runs every system once per round, `repeat` rounds, so that drift on the machine hits all alike;
/// each round starts with the next system, so that none always runs first (or right after another).
Row alternate(Row row, const std::vector<std::pair<std::string, Measurement*>>& systems, int repeat);

/// Options for one measurement: payload size, count per run, carrier.
Options options_for(std::size_t size, std::size_t count, const std::string& carrier);

}  // namespace plexus::bench
