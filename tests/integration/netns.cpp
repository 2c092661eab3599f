#include "netns.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>

#include "harness.hpp"

namespace plexus::test {
namespace {

// iproute2 keeps a named namespace as a bind mount here (NETNS_RUN_DIR).
const std::string netns_dir = "/var/run/netns/";
// Every namespace these tests make starts with this, then the creating pid: "plx<pid>-".
const std::string name_prefix = "plx";

std::string command_line(const std::vector<std::string>& argv) {
    std::string line;
    for (const auto& a : argv)
        line += (line.empty() ? "" : " ") + a;
    return line;
}

const std::string& ip() {
    static const std::string path = find_program("ip");
    return path;
}

/// The pid in a name this file made ("plx123-0-h1" → 123), or -1 for anybody else's namespace.
pid_t creator_of(const std::string& name) {
    if (name.rfind(name_prefix, 0) != 0)
        return -1;
    const std::size_t dash = name.find('-', name_prefix.size());
    const std::string digits = name.substr(name_prefix.size(), dash - name_prefix.size());
    if (dash == std::string::npos || digits.empty() ||
        digits.find_first_not_of("0123456789") != std::string::npos)
        return -1;
    return static_cast<pid_t>(std::stol(digits));
}

std::vector<pid_t> pids_in(const std::string& ns) {
    std::vector<pid_t> pids;
    std::istringstream listed(run_command({ip(), "netns", "pids", ns}).out);
    for (long pid = 0; listed >> pid;)
        pids.push_back(static_cast<pid_t>(pid));
    return pids;
}

/// Kills whatever still runs inside `ns`, then deletes it (which deletes its ends of the veths).
/// A namespace outlives its name while a process holds it, so the kill comes first.
void remove_namespace(const std::string& ns) noexcept {
    try {
        eventually(
            [&] {
                const auto pids = pids_in(ns);
                for (pid_t pid : pids)
                    ::kill(pid, SIGKILL);
                return pids.empty();
            },
            5s);
        const auto deleted = run_command({ip(), "netns", "delete", ns});
        if (deleted.status != 0)
            std::cerr << "netns: cannot delete " << ns << ": " << deleted.err;
    } catch (const std::exception& e) {
        std::cerr << "netns: cannot remove " << ns << ": " << e.what() << '\n';
    }
}

}  // namespace

CommandResult run_command(const std::vector<std::string>& argv, std::chrono::milliseconds timeout) {
    std::vector<std::string> resolved = argv;
    if (resolved.at(0).find('/') == std::string::npos)
        resolved[0] = find_program(resolved[0]);
    std::vector<char*> args;
    for (auto& a : resolved)
        args.push_back(a.data());
    args.push_back(nullptr);

    int out[2];
    int err[2];
    if (::pipe2(out, O_CLOEXEC) != 0 || ::pipe2(err, O_CLOEXEC) != 0)
        throw std::runtime_error("pipe failed");
    const pid_t pid = ::fork();
    if (pid < 0)
        throw std::runtime_error("fork failed");
    if (pid == 0) {
        ::setpgid(0, 0);  // so that a timeout kills whatever the command started as well
        const int in = ::open("/dev/null", O_RDONLY);
        ::dup2(in, 0);
        ::dup2(out[1], 1);
        ::dup2(err[1], 2);
        ::execv(args[0], args.data());
        ::_exit(127);
    }
    ::close(out[1]);
    ::close(err[1]);

    CommandResult result;
    // Read both pipes as they fill: a command that writes much to one would block on it otherwise.
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    pollfd fds[2] = {{out[0], POLLIN, 0}, {err[0], POLLIN, 0}};
    std::string* sinks[2] = {&result.out, &result.err};
    bool timed_out = false;
    while (fds[0].fd >= 0 || fds[1].fd >= 0) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) {
            timed_out = true;
            break;
        }
        if (::poll(fds, 2, static_cast<int>(left.count())) < 0 && errno != EINTR)
            break;
        for (int i = 0; i < 2; ++i) {
            if (fds[i].fd < 0 || fds[i].revents == 0)
                continue;
            char buffer[4096];
            const ssize_t n = ::read(fds[i].fd, buffer, sizeof buffer);
            if (n > 0) {
                sinks[i]->append(buffer, static_cast<std::size_t>(n));
            } else if (n == 0 || errno != EINTR) {
                ::close(fds[i].fd);
                fds[i].fd = -1;
            }
        }
    }
    for (const auto& f : fds) {
        if (f.fd >= 0)
            ::close(f.fd);
    }
    if (timed_out)
        ::kill(-pid, SIGKILL);
    int raw = 0;
    // Both pipes are closed, so the command has exited or is about to: this wait is short.
    while (::waitpid(pid, &raw, 0) < 0 && errno == EINTR) {
    }
    if (timed_out) {
        result.status = -1;
        result.err += "(killed after " + std::to_string(timeout.count()) + " ms)";
    } else {
        result.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
    }
    return result;
}

std::string run_checked(const std::vector<std::string>& argv, std::chrono::milliseconds timeout) {
    auto result = run_command(argv, timeout);
    if (result.status != 0) {
        throw std::runtime_error("`" + command_line(argv) + "` exited with " + std::to_string(result.status) +
                                 ": " + result.err);
    }
    return result.out;
}

std::string find_program(const std::string& name) {
    const char* path = std::getenv("PATH");
    // The sbin directories too: ip and nft live there and a CI user's PATH may lack them.
    std::string dirs = std::string(path ? path : "") + ":/usr/sbin:/sbin:/usr/bin:/bin";
    std::istringstream split(dirs);
    for (std::string dir; std::getline(split, dir, ':');) {
        if (dir.empty())
            continue;
        const std::string candidate = dir + "/" + name;
        if (::access(candidate.c_str(), X_OK) == 0)
            return candidate;
    }
    throw std::runtime_error("no program '" + name + "' in PATH (" + dirs + ")");
}

std::vector<std::string> list_namespaces() {
    std::vector<std::string> names;
    std::istringstream lines(run_checked({ip(), "netns", "list"}));
    for (std::string line; std::getline(lines, line);) {
        const std::string name = line.substr(0, line.find(' '));  // "NAME (id: 3)"
        if (!name.empty())
            names.push_back(name);
    }
    return names;
}

bool process_running(pid_t pid) {
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    if (!std::getline(stat, line))
        return false;
    // "PID (COMMAND) STATE ...": the command may hold spaces and parentheses, the state follows the last ')'.
    const std::size_t close = line.rfind(')');
    if (close == std::string::npos || close + 2 >= line.size())
        return false;
    const char state = line[close + 2];
    return state != 'Z' && state != 'X';
}

bool netns_skipped() {
    const char* skip = std::getenv("PLEXUS_SKIP_NETNS");
    return skip != nullptr && std::string(skip) == "1";
}

NetnsUnavailable::NetnsUnavailable(const std::string& why)
    : std::runtime_error("network namespaces cannot be made here: " + why +
                         "; set PLEXUS_SKIP_NETNS=1 to skip these tests") {}

void remove_stale_namespaces() {
    for (const auto& name : list_namespaces()) {
        const pid_t creator = creator_of(name);
        if (creator > 0 && creator != ::getpid() && !process_running(creator))
            remove_namespace(name);
    }
}

Host::Host(std::string name, std::string address, std::string bridge_port)
    : name_(std::move(name)), address_(std::move(address)), bridge_port_(std::move(bridge_port)) {}

std::vector<std::string> Host::wrap(const std::vector<std::string>& argv) const {
    // `ip netns exec` execs the program (no extra process), so a Process's pid is the program's.
    std::vector<std::string> wrapped{ip(), "netns", "exec", name_};
    wrapped.insert(wrapped.end(), argv.begin(), argv.end());
    return wrapped;
}

CommandResult Host::run(const std::string& command, std::chrono::milliseconds timeout) const {
    return run_command(wrap({"/bin/sh", "-c", command}), timeout);
}

std::string Host::run_checked(const std::string& command, std::chrono::milliseconds timeout) const {
    return plexus::test::run_checked(wrap({"/bin/sh", "-c", command}), timeout);
}

pid_t Host::fork_inside(const std::function<int()>& body) const {
    const std::string path = netns_dir + name_;  // built before fork: the child only makes system calls
    const pid_t pid = ::fork();
    if (pid < 0)
        throw std::runtime_error("fork failed");
    if (pid == 0) {
        const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0 || ::setns(fd, CLONE_NEWNET) != 0)
            ::_exit(126);
        int status = 125;
        try {
            status = body();
        } catch (...) {
        }
        ::_exit(status);
    }
    return pid;
}

Network::Network(int hosts) {
    static std::atomic<int> counter{0};
    prefix_ = name_prefix + std::to_string(::getpid()) + "-" + std::to_string(counter++) + "-";
    if (::geteuid() != 0)
        throw NetnsUnavailable("not running as root (uid " + std::to_string(::geteuid()) + ")");
    try {
        ip();
    } catch (const std::exception& e) {
        throw NetnsUnavailable(std::string("iproute2 is missing: ") + e.what());
    }
    remove_stale_namespaces();

    const std::string switch_name = prefix_ + "sw";
    const auto made = run_command({ip(), "netns", "add", switch_name});
    if (made.status != 0)
        throw NetnsUnavailable("`ip netns add` failed: " + made.err);
    switch_ = std::make_unique<Host>(switch_name, "", "br0");
    try {
        run_checked({ip(), "-n", switch_name, "link", "set", "lo", "up"});
        // No spanning tree and no forward delay: ports forward as soon as they are up. No IGMP
        // snooping: the bridge floods every group to every port, so a group works without a querier.
        run_checked({ip(), "-n", switch_name, "link", "add", "br0", "type", "bridge", "stp_state", "0",
                     "forward_delay", "0", "mcast_snooping", "0"});
        run_checked({ip(), "-n", switch_name, "link", "set", "br0", "up"});
        for (int k = 0; k < hosts; ++k)
            add_host(k);
        // A test's first packet must not race the links coming up.
        for (const auto& host : hosts_) {
            const bool up = eventually(
                [&] {
                    return run_command({ip(), "-n", host->name(), "-o", "link", "show", "eth0"})
                               .out.find("state UP") != std::string::npos;
                },
                10s);
            if (!up)
                throw std::runtime_error("eth0 of " + host->name() + " did not come up");
        }
    } catch (...) {
        remove_all();
        throw;
    }
}

void Network::add_host(int k) {
    const std::string name = prefix_ + "h" + std::to_string(k);
    const std::string address = "10.77.0." + std::to_string(k + 1);
    const std::string port = "v" + std::to_string(k);  // only unique within the switch namespace
    run_checked({ip(), "netns", "add", name});
    hosts_.push_back(std::make_unique<Host>(name, address, port));
    const std::string& sw = switch_->name();
    // Made inside the switch with its peer placed straight into the host: no name ever exists
    // in the root namespace, where parallel runs would collide.
    run_checked({ip(), "-n", sw, "link", "add", port, "type", "veth", "peer", "name", "eth0", "netns", name});
    run_checked({ip(), "-n", sw, "link", "set", port, "master", "br0"});
    run_checked({ip(), "-n", sw, "link", "set", port, "up"});
    run_checked({ip(), "-n", name, "link", "set", "lo", "up"});
    run_checked({ip(), "-n", name, "address", "add", address + "/24", "dev", "eth0"});
    run_checked({ip(), "-n", name, "link", "set", "eth0", "up"});
    // Without a route for the multicast range, sends to a group fail with "network unreachable"
    // and joins pick no interface. Not a default route: a wrong address should fail fast.
    run_checked({ip(), "-n", name, "route", "add", "224.0.0.0/4", "dev", "eth0"});
}

Network::~Network() {
    remove_all();
}

std::vector<std::string> Network::namespaces() const {
    std::vector<std::string> names;
    for (const auto& host : hosts_)
        names.push_back(host->name());
    if (switch_)
        names.push_back(switch_->name());
    return names;
}

void Network::remove_all() noexcept {
    for (const auto& name : namespaces())  // hosts first: their veths leave the bridge with them
        remove_namespace(name);
    hosts_.clear();
    switch_.reset();
}

}  // namespace plexus::test
