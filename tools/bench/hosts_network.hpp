#pragma once
// Separate hosts on one machine for `plexus-bench hosts`: each host is a network namespace with its
// own eth0 (one end of a veth) and a private address, plugged into a bridge that lives in a "switch"
// namespace of its own, so that hosts reach each other (unicast and multicast) and nothing else.
// The same layout as the integration tests' (tests/integration/netns.cpp), written again here:
// the bench does not link test code.
//
// Needs root and iproute2. Names carry this process's pid ("pxb<pid>-h1"). Everything made is
// removed when the HostsNetwork is destroyed; if the bench dies first (a signal, _exit, SIGKILL), a
// small janitor process that it started waits for that and removes it; namespaces of runs whose
// janitor died too are removed by the next run.

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace plexus::bench {

/// This machine cannot make namespaces (not root, no `ip`, no kernel support), as opposed to a
/// failure half-way, which is a plain runtime_error.
class NetnsUnavailable : public std::runtime_error {
public:
    explicit NetnsUnavailable(const std::string& why)
        : std::runtime_error("network namespaces cannot be made here: " + why) {}
};

/// Bytes and packets an interface has sent.
struct LinkCounters {
    std::uint64_t tx_bytes = 0;
    std::uint64_t tx_packets = 0;
};

/// What a command run to completion did: its exit status and its output (stdout and stderr).
struct CommandResult {
    int status = -1;
    std::string output;
};

/// Runs argv (argv[0] an absolute path) and waits for it.
CommandResult run_command(const std::vector<std::string>& argv);

class HostsNetwork {
public:
    /// `hosts` hosts; host k is 10.78.0.(k+1)/24 on its eth0. Throws NetnsUnavailable or
    /// runtime_error (after removing what it made). If the bench dies, the janitor also removes
    /// `scratch_dir` (the run's temporary directory: sockets, logs, the secret), if given.
    explicit HostsNetwork(int hosts, const std::string& scratch_dir = "");
    ~HostsNetwork();
    HostsNetwork(const HostsNetwork&) = delete;
    HostsNetwork& operator=(const HostsNetwork&) = delete;

    int size() const { return static_cast<int>(hosts_.size()); }
    /// The namespace of host k.
    const std::string& name(int k) const { return hosts_.at(static_cast<std::size_t>(k)); }
    /// Host k's IPv4 address on its eth0.
    std::string address(int k) const;
    /// argv prefixed with `ip netns exec NAME`: a ChildProcess of it runs on host k (ip execs it:
    /// the pid is the program's).
    std::vector<std::string> wrap(int k, const std::vector<std::string>& argv) const;
    /// Runs `body` on a thread of this process that has entered host k's network namespace, and
    /// waits for it; sockets it makes stay in that namespace. Rethrows what `body` throws.
    void inside(int k, const std::function<void()>& body) const;
    /// What host k's eth0 has sent so far.
    LinkCounters eth0(int k) const;

private:
    static void inside_namespace(const std::string& ns, const std::function<void()>& body);
    void add_host(int k);
    void start_janitor(const std::string& scratch_dir);
    void remove_all() noexcept;

    std::string ip_;
    std::string prefix_;  ///< "pxb<pid>-"
    std::string switch_;
    std::vector<std::string> hosts_;
    int janitor_pipe_ = -1;  ///< its write end; the janitor cleans up when it closes
    pid_t janitor_ = -1;
};

}  // namespace plexus::bench
