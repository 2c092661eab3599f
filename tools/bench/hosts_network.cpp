#include "hosts_network.hpp"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "child_process.hpp"

namespace plexus::bench {

using namespace std::chrono_literals;

namespace {

// iproute2 keeps a named namespace as a bind mount here.
const std::string netns_dir = "/var/run/netns/";
// Every namespace of this bench starts with this and the creating pid: "pxb<pid>-".
const std::string name_prefix = "pxb";
// Not the tests' 10.77.0.0/24: nothing depends on it (each namespace is private), but a reader
// of `ip netns` output can tell the two apart.
const std::string subnet = "10.78.0.";

std::string command_line(const std::vector<std::string>& argv) {
    std::string line;
    for (const auto& a : argv)
        line += (line.empty() ? "" : " ") + a;
    return line;
}

std::string find_ip() {
    for (const char* candidate : {"/usr/sbin/ip", "/sbin/ip", "/usr/bin/ip", "/bin/ip"}) {
        if (::access(candidate, X_OK) == 0)
            return candidate;
    }
    throw NetnsUnavailable("iproute2's `ip` is not installed (looked in /usr/sbin, /sbin, /usr/bin, /bin)");
}

std::string run_checked(const std::vector<std::string>& argv) {
    auto result = run_command(argv);
    if (result.status != 0) {
        throw std::runtime_error("`" + command_line(argv) + "` exited with " + std::to_string(result.status) +
                                 ": " + result.output);
    }
    return result.output;
}

/// False for a process that does not exist or has exited but was not reaped yet.
bool process_running(pid_t pid) {
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    if (!std::getline(stat, line))
        return false;
    const std::size_t close = line.rfind(')');  // "PID (COMMAND) STATE ..."
    if (close == std::string::npos || close + 2 >= line.size())
        return false;
    return line[close + 2] != 'Z' && line[close + 2] != 'X';
}

/// The pid in a name this bench made ("pxb123-h1" -> 123), or -1 for anybody else's namespace.
pid_t creator_of(const std::string& name) {
    if (name.rfind(name_prefix, 0) != 0)
        return -1;
    const std::size_t dash = name.find('-', name_prefix.size());
    if (dash == std::string::npos || dash == name_prefix.size())
        return -1;
    const std::string digits = name.substr(name_prefix.size(), dash - name_prefix.size());
    if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9)
        return -1;
    return static_cast<pid_t>(std::stol(digits));
}

std::vector<std::string> list_namespaces(const std::string& ip) {
    std::vector<std::string> names;
    std::istringstream lines(run_checked({ip, "netns", "list"}));
    for (std::string line; std::getline(lines, line);) {
        const std::string name = line.substr(0, line.find(' '));  // "NAME (id: 3)"
        if (!name.empty())
            names.push_back(name);
    }
    return names;
}

/// Kills what still runs inside `ns`, then deletes it (and with it its ends of the veths).
void remove_namespace(const std::string& ip, const std::string& ns) noexcept {
    try {
        poll_until(
            [&] {
                std::istringstream listed(run_command({ip, "netns", "pids", ns}).output);
                bool any = false;
                for (long pid = 0; listed >> pid; any = true)
                    ::kill(static_cast<pid_t>(pid), SIGKILL);
                return !any;
            },
            5s);
        const auto deleted = run_command({ip, "netns", "delete", ns});
        if (deleted.status != 0)
            std::cerr << "plexus-bench: cannot delete namespace " << ns << ": " << deleted.output;
    } catch (const std::exception& e) {
        std::cerr << "plexus-bench: cannot remove namespace " << ns << ": " << e.what() << '\n';
    }
}

/// Writes a value into a /proc/sys file of the calling thread's network namespace; errors ignored
/// (a kernel without IPv6 has no such file).
void set_sysctl(const std::string& path, const std::string& value) {
    std::ofstream out(path);
    out << value;
}

}  // namespace

CommandResult run_command(const std::vector<std::string>& argv) {
    std::vector<char*> args;
    for (const auto& a : argv)
        args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    int out[2];
    if (::pipe2(out, O_CLOEXEC) != 0)
        throw std::runtime_error("pipe failed");
    const pid_t pid = ::fork();
    if (pid < 0) {
        ::close(out[0]);
        ::close(out[1]);
        throw std::runtime_error("fork failed");
    }
    if (pid == 0) {
        const int in = ::open("/dev/null", O_RDONLY);
        ::dup2(in, 0);
        ::dup2(out[1], 1);
        ::dup2(out[1], 2);
        ::execv(args[0], args.data());
        ::_exit(127);
    }
    ::close(out[1]);
    CommandResult result;
    char buffer[4096];
    for (;;) {
        const ssize_t n = ::read(out[0], buffer, sizeof buffer);
        if (n > 0)
            result.output.append(buffer, static_cast<std::size_t>(n));
        else if (n == 0 || errno != EINTR)
            break;
    }
    ::close(out[0]);
    int raw = 0;
    while (::waitpid(pid, &raw, 0) < 0 && errno == EINTR) {
    }
    result.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
    return result;
}

HostsNetwork::HostsNetwork(int hosts, const std::string& scratch_dir) {
    if (::geteuid() != 0)
        throw NetnsUnavailable("not running as root (uid " + std::to_string(::geteuid()) + ")");
    ip_ = find_ip();
    prefix_ = name_prefix + std::to_string(::getpid()) + "-";
    // Namespaces of earlier runs that died together with their janitor.
    for (const auto& name : list_namespaces(ip_)) {
        const pid_t creator = creator_of(name);
        if (creator > 0 && creator != ::getpid() && !process_running(creator))
            remove_namespace(ip_, name);
    }
    start_janitor(scratch_dir);
    const std::string switch_name = prefix_ + "sw";
    const auto made = run_command({ip_, "netns", "add", switch_name});
    if (made.status != 0) {
        remove_all();
        throw NetnsUnavailable("`ip netns add` failed: " + made.output);
    }
    switch_ = switch_name;
    try {
        inside_namespace(switch_, [] {
            set_sysctl("/proc/sys/net/ipv6/conf/all/disable_ipv6", "1");
            set_sysctl("/proc/sys/net/ipv6/conf/default/disable_ipv6", "1");
        });
        run_checked({ip_, "-n", switch_, "link", "set", "lo", "up"});
        // No spanning tree, no forward delay: ports forward once up. No IGMP snooping: the bridge
        // floods every group to every port, so groups work without a querier.
        run_checked({ip_, "-n", switch_, "link", "add", "br0", "type", "bridge", "stp_state", "0",
                     "forward_delay", "0", "mcast_snooping", "0"});
        run_checked({ip_, "-n", switch_, "link", "set", "br0", "up"});
        for (int k = 0; k < hosts; ++k)
            add_host(k);
        // The first packet must not race the links coming up.
        for (const auto& host : hosts_) {
            const bool up = poll_until(
                [&] {
                    return run_command({ip_, "-n", host, "-o", "link", "show", "eth0"})
                               .output.find("state UP") != std::string::npos;
                },
                10s);
            if (!up)
                throw std::runtime_error("eth0 of " + host + " did not come up");
        }
    } catch (...) {
        remove_all();
        throw;
    }
}

HostsNetwork::~HostsNetwork() {
    remove_all();
}

void HostsNetwork::inside_namespace(const std::string& ns, const std::function<void()>& body) {
    const std::string path = netns_dir + ns;
    std::exception_ptr failure;
    std::thread thread([&] {
        try {
            const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
            if (fd < 0)
                throw std::runtime_error("cannot open " + path);
            const int entered = ::setns(fd, CLONE_NEWNET);
            ::close(fd);
            if (entered != 0)
                throw std::runtime_error("cannot enter the network namespace " + ns);
            body();
        } catch (...) {
            failure = std::current_exception();
        }
    });
    thread.join();
    if (failure)
        std::rethrow_exception(failure);
}

void HostsNetwork::add_host(int k) {
    const std::string name = prefix_ + "h" + std::to_string(k);
    const std::string port = "v" + std::to_string(k);  // only unique inside the switch namespace
    run_checked({ip_, "netns", "add", name});
    hosts_.push_back(name);
    // No IPv6: its router solicitations and MLD reports would add to what eth0 sends.
    inside_namespace(name, [] {
        set_sysctl("/proc/sys/net/ipv6/conf/all/disable_ipv6", "1");
        set_sysctl("/proc/sys/net/ipv6/conf/default/disable_ipv6", "1");
    });
    // Made inside the switch with its peer placed straight into the host: no name ever exists in
    // the root namespace, where parallel runs (and the tests) would collide.
    run_checked(
        {ip_, "-n", switch_, "link", "add", port, "type", "veth", "peer", "name", "eth0", "netns", name});
    run_checked({ip_, "-n", switch_, "link", "set", port, "master", "br0"});
    run_checked({ip_, "-n", switch_, "link", "set", port, "up"});
    run_checked({ip_, "-n", name, "link", "set", "lo", "up"});
    run_checked({ip_, "-n", name, "address", "add", address(k) + "/24", "dev", "eth0"});
    run_checked({ip_, "-n", name, "link", "set", "eth0", "up"});
    // Without a route for the multicast range, sends to a group fail ("network unreachable").
    run_checked({ip_, "-n", name, "route", "add", "224.0.0.0/4", "dev", "eth0"});
}

void HostsNetwork::start_janitor(const std::string& scratch_dir) {
    // A shell that waits for the bench's end of a pipe to close (whatever ends the bench), then
    // removes this run's namespaces with whatever still runs in them, and the scratch directory.
    // Its own session: a Ctrl-C on the terminal does not reach it.
    if (scratch_dir.find('\'') != std::string::npos)
        throw std::runtime_error("a quote in " + scratch_dir);
    std::string script =
        "trap '' INT TERM HUP; cat <&3 >/dev/null; "
        "for ns in $(" +
        ip_ + " netns list | cut -d' ' -f1 | grep '^" + prefix_ +
        "'); do "
        "for p in $(" +
        ip_ + " netns pids $ns); do kill -9 $p; done; " + ip_ + " netns delete $ns; done 2>/dev/null";
    if (!scratch_dir.empty())
        script += "; rm -rf '" + scratch_dir + "'";
    int pipe[2];
    if (::pipe2(pipe, O_CLOEXEC) != 0)
        throw std::runtime_error("pipe failed");
    const pid_t pid = ::fork();
    if (pid < 0)
        throw std::runtime_error("fork failed");
    if (pid == 0) {
        ::setsid();
        const int null = ::open("/dev/null", O_RDWR);
        ::dup2(null, 0);
        ::dup2(null, 1);
        if (pipe[0] == 3)
            ::fcntl(3, F_SETFD, 0);
        else
            ::dup2(pipe[0], 3);  // without close-on-exec; the write end closes at exec
        ::execl("/bin/sh", "sh", "-c", script.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
    ::close(pipe[0]);
    janitor_pipe_ = pipe[1];
    janitor_ = pid;
}

void HostsNetwork::remove_all() noexcept {
    for (const auto& name : hosts_)  // hosts first: their veths leave the bridge with them
        remove_namespace(ip_, name);
    hosts_.clear();
    if (!switch_.empty())
        remove_namespace(ip_, switch_);
    switch_.clear();
    if (janitor_pipe_ >= 0) {
        ::close(janitor_pipe_);  // the janitor looks once more, finds nothing and exits
        janitor_pipe_ = -1;
    }
    if (janitor_ > 0) {
        int status = 0;
        while (::waitpid(janitor_, &status, 0) < 0 && errno == EINTR) {
        }
        janitor_ = -1;
    }
}

std::string HostsNetwork::address(int k) const {
    return subnet + std::to_string(k + 1);
}

std::vector<std::string> HostsNetwork::wrap(int k, const std::vector<std::string>& argv) const {
    std::vector<std::string> wrapped{ip_, "netns", "exec", name(k)};
    wrapped.insert(wrapped.end(), argv.begin(), argv.end());
    return wrapped;
}

void HostsNetwork::inside(int k, const std::function<void()>& body) const {
    inside_namespace(name(k), body);
}

LinkCounters HostsNetwork::eth0(int k) const {
    LinkCounters counters;
    bool found = false;
    inside(k, [&] {
        // /proc/thread-self/net is this thread's namespace; /sys/class/net would be the mount's.
        std::ifstream dev("/proc/thread-self/net/dev");
        for (std::string line; std::getline(dev, line);) {
            const std::size_t colon = line.find(':');
            if (colon == std::string::npos)
                continue;
            std::string interface = line.substr(0, colon);
            interface.erase(0, interface.find_first_not_of(' '));
            if (interface != "eth0")
                continue;
            // rx: bytes packets errs drop fifo frame compressed multicast; tx: bytes packets ...
            std::istringstream fields(line.substr(colon + 1));
            std::uint64_t value = 0;
            for (int i = 0; i < 8; ++i)
                fields >> value;
            fields >> counters.tx_bytes >> counters.tx_packets;
            found = static_cast<bool>(fields);
        }
    });
    if (!found)
        throw std::runtime_error("no counters for eth0 of " + name(k));
    return counters;
}

}  // namespace plexus::bench
