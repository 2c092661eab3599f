#pragma once
// Separate hosts on one machine, for tests that must cross a real network: each host is a network
// namespace with its own `eth0` and private address, plugged into a bridge that lives in a
// "switch" namespace of its own, so hosts see each other (unicast and multicast) and nothing else.
// Needs root and iproute2. Everything a Network makes is removed when it is destroyed, also when
// a test fails; namespaces left by a run that crashed are removed by the next run.

#include <sys/types.h>

#include <chrono>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace plexus::test {

/// What a command run to completion did: exit code (128+signal if killed, -1 on timeout) and output.
struct CommandResult {
    int status = -1;
    std::string out;
    std::string err;
};

/// Runs argv (argv[0] looked up in PATH, then in the sbin directories) and waits for it.
CommandResult run_command(const std::vector<std::string>& argv,
                          std::chrono::milliseconds timeout = std::chrono::seconds(30));

/// run_command, throwing with the command line and its stderr when it does not exit 0.
std::string run_checked(const std::vector<std::string>& argv,
                        std::chrono::milliseconds timeout = std::chrono::seconds(30));

/// Absolute path of a program found in PATH (or /usr/sbin, /sbin); throws if there is none.
std::string find_program(const std::string& name);

/// Names of the network namespaces that exist now (`ip netns list`).
std::vector<std::string> list_namespaces();

/// True while `pid` runs. A zombie does not: a killed process whose parent has not reaped it yet
/// (a crashed run's orphans wait for whatever init the container has).
bool process_running(pid_t pid);

/// True when PLEXUS_SKIP_NETNS=1: tests that need namespaces skip themselves.
bool netns_skipped();

/// Thrown when this machine cannot make network namespaces at all (not root, no `ip`, no kernel
/// support), as opposed to a failure half-way, which is a plain runtime_error.
class NetnsUnavailable : public std::runtime_error {
public:
    explicit NetnsUnavailable(const std::string& why);
};

/// One host of a Network: a network namespace with `lo` and `eth0` up.
class Host {
public:
    Host(std::string name, std::string address, std::string bridge_port);
    /// The namespace's name (as `ip netns` knows it).
    const std::string& name() const { return name_; }
    /// Its IPv4 address on eth0, without prefix length ("" for the switch).
    const std::string& address() const { return address_; }
    /// This host's end of its cable inside the switch namespace, for tc/nft on the switch side.
    const std::string& bridge_port() const { return bridge_port_; }
    /// argv prefixed with `ip netns exec NAME`, so that a Process runs it inside this host.
    std::vector<std::string> wrap(const std::vector<std::string>& argv) const;
    /// Runs `sh -c command` inside this host.
    CommandResult run(const std::string& command,
                      std::chrono::milliseconds timeout = std::chrono::seconds(30)) const;
    /// run(), throwing with the command and its stderr unless it exits 0; returns stdout.
    std::string run_checked(const std::string& command,
                            std::chrono::milliseconds timeout = std::chrono::seconds(30)) const;
    /// Runs `body` in a forked child that has entered this host's namespace; returns the child's
    /// pid (the caller waits for it) — for socket code a test wants to run on a host.
    pid_t fork_inside(const std::function<int()>& body) const;

private:
    std::string name_;
    std::string address_;
    std::string bridge_port_;
};

/// A switch and `hosts` hosts on it; host k has address 10.77.0.(k+1)/24 on its eth0.
class Network {
public:
    /// Throws NetnsUnavailable (with a message that says PLEXUS_SKIP_NETNS=1 skips) if
    /// namespaces cannot be made here, runtime_error for any later failure (after undoing it).
    explicit Network(int hosts);
    ~Network();
    Network(const Network&) = delete;
    Network& operator=(const Network&) = delete;

    Host& host(int k) { return *hosts_.at(static_cast<std::size_t>(k)); }
    int size() const { return static_cast<int>(hosts_.size()); }
    /// The switch namespace (holds the bridge `br0` and every host's bridge_port()).
    Host& bridge() { return *switch_; }
    /// Every namespace this network made, hosts and switch.
    std::vector<std::string> namespaces() const;

private:
    void add_host(int k);
    void remove_all() noexcept;

    std::string prefix_;  // "plx<pid>-<counter>-": unique per network, tells stale ones by pid
    std::unique_ptr<Host> switch_;
    std::vector<std::unique_ptr<Host>> hosts_;
};

/// Removes namespaces that earlier runs of these tests left behind: those whose creating process
/// (the pid in their name) is no longer running, with whatever still runs inside them. A reused
/// pid keeps them until that process ends too. Network's constructor calls it.
void remove_stale_namespaces();

}  // namespace plexus::test

/// First line of a test that needs network namespaces: skips it when PLEXUS_SKIP_NETNS=1. Without
/// that variable, a machine that cannot make namespaces fails the test (Network's constructor
/// throws NetnsUnavailable, which says why and how to skip).
#define PLEXUS_NEEDS_NETNS()                                                                \
    do {                                                                                    \
        if (::plexus::test::netns_skipped())                                                \
            GTEST_SKIP() << "PLEXUS_SKIP_NETNS=1: tests on network namespaces are skipped"; \
    } while (false)
