#pragma once
// plexus-bench hosts: Plexus across hosts made of network namespaces (hosts_network.hpp), each
// figure next to a floor measured in the same run over the same veth (hosts_floor.hpp).
//
// Host 0 runs plexus-names, hosts 1 to 4 plexusd, all with a deployment secret; hosts 1 and 2 also
// run a second deployment without one (--insecure), for the cost of authentication. The bench's
// client threads stay in the bench process and reach each daemon through its Unix socket (a path
// in the file system, reachable from any network namespace): the data between the daemons crosses
// the veths, and only the floors' sockets are made inside the hosts.

#include <string>

namespace plexus::bench {

struct HostsOptions {
    bool quick = false;        ///< fewer messages and one run per system: a smoke test
    int repeat = 5;            ///< runs per system; medians are reported
    bool json = false;         ///< one JSON object per line instead of tables
    std::string plexusd;       ///< the daemon binary
    std::string plexus_names;  ///< the name server binary; "": next to plexusd's
    bool calls = false;        ///< instead of the other parts: call round trips (hosts_calls.cpp)
};

/// Exit status when network namespaces cannot be made here: nothing was measured.
inline constexpr int hosts_unavailable_status = 77;

int run_hosts(const HostsOptions& options);

class HostsNetwork;
class TempDir;
/// The calls part (--calls): a caller on host 1's daemon, a served port on host 2's, against the
/// relay floor with the same hops and a direct TCP ping-pong; on hosts `run_hosts` has made.
int run_hosts_calls(const HostsOptions& options, const HostsNetwork& network, const TempDir& dir);

}  // namespace plexus::bench
