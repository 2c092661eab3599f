// Plexus on separate hosts: the network-namespace fixture itself (hosts reach each other by
// unicast and multicast, and nothing is left behind), then daemons on different hosts carrying
// data through a name server on a host of its own.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "harness.hpp"
#include "netns.hpp"

namespace plexus::test {
namespace netns_test {

using nlohmann::json;

const char* const group = "239.255.77.1";
constexpr int group_port = 47701;

/// Reads what is there on `fd` within `timeout`; "" if nothing came.
std::string read_within(int fd, std::chrono::milliseconds timeout) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0)
        return "";
    char buffer[256];
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    return n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : "";
}

/// Inside a host: joins the group on eth0, says so on `ready`, then writes "SENDER-ADDRESS PAYLOAD"
/// of the first datagram to `got`. Runs in a forked child: system calls only, exit status says how far it
/// got.
int receive_one(const std::string& address, int ready, int got) {
    const int s = ::socket(AF_INET, SOCK_DGRAM, 0);
    const int on = 1;
    ::setsockopt(s, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
    sockaddr_in bound{};
    bound.sin_family = AF_INET;
    bound.sin_port = htons(group_port);
    bound.sin_addr.s_addr = ::inet_addr(group);
    if (::bind(s, reinterpret_cast<sockaddr*>(&bound), sizeof bound) != 0)
        return 2;
    ip_mreq join{};
    join.imr_multiaddr.s_addr = ::inet_addr(group);
    join.imr_interface.s_addr = ::inet_addr(address.c_str());
    if (::setsockopt(s, IPPROTO_IP, IP_ADD_MEMBERSHIP, &join, sizeof join) != 0)
        return 3;
    const timeval patience{20, 0};  // the parent gives up before this; it only bounds an orphan
    ::setsockopt(s, SOL_SOCKET, SO_RCVTIMEO, &patience, sizeof patience);
    if (::write(ready, "r", 1) != 1)
        return 4;
    char buffer[128];
    sockaddr_in from{};
    socklen_t from_size = sizeof from;
    const ssize_t n = ::recvfrom(s, buffer, sizeof buffer, 0, reinterpret_cast<sockaddr*>(&from), &from_size);
    if (n <= 0)
        return 5;
    const std::string report =
        std::string(::inet_ntoa(from.sin_addr)) + " " + std::string(buffer, static_cast<std::size_t>(n));
    return ::write(got, report.data(), report.size()) == static_cast<ssize_t>(report.size()) ? 0 : 6;
}

/// Inside a host: sends `payload` once to the group out of eth0, with TTL 1 as a LAN would.
int send_one(const std::string& address, const std::string& payload) {
    const int s = ::socket(AF_INET, SOCK_DGRAM, 0);
    in_addr out{};
    out.s_addr = ::inet_addr(address.c_str());
    ::setsockopt(s, IPPROTO_IP, IP_MULTICAST_IF, &out, sizeof out);
    const unsigned char ttl = 1;
    ::setsockopt(s, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(group_port);
    to.sin_addr.s_addr = ::inet_addr(group);
    const ssize_t n =
        ::sendto(s, payload.data(), payload.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
    return n == static_cast<ssize_t>(payload.size()) ? 0 : 1;
}

TEST(Netns_test, EveryHostReachesEveryOtherHost) {
    PLEXUS_NEEDS_NETNS();
    Network net(4);
    for (int from = 0; from < net.size(); ++from) {
        const std::string own = net.host(from).run_checked("ip -4 -o address show dev eth0");
        EXPECT_NE(own.find(net.host(from).address() + "/24"), std::string::npos) << own;
        for (int to = 0; to < net.size(); ++to) {
            if (to == from)
                continue;
            auto ping = net.host(from).run("ping -c1 -W2 " + net.host(to).address());
            EXPECT_EQ(ping.status, 0) << "host " << from << " → " << to << ": " << ping.out << ping.err;
        }
    }
    // And no further: a host knows no route beyond its own network.
    EXPECT_NE(net.host(1).run("ping -c1 -W1 192.0.2.1").status, 0);
}

TEST(Netns_test, AMulticastDatagramCrossesTheBridge) {
    PLEXUS_NEEDS_NETNS();
    Network net(4);
    int ready[2];
    int got[2];
    ASSERT_EQ(::pipe(ready), 0);
    ASSERT_EQ(::pipe(got), 0);
    const Host& receiver_host = net.host(3);
    const pid_t receiver =
        receiver_host.fork_inside([&] { return receive_one(receiver_host.address(), ready[1], got[1]); });
    ::close(ready[1]);
    ::close(got[1]);
    ASSERT_EQ(read_within(ready[0], 10s), "r") << "the receiver did not join the group";

    // Datagrams may be lost, so send until one arrives rather than trusting the first.
    std::string report;
    const bool arrived = eventually(
        [&] {
            const Host& sender = net.host(1);
            const pid_t child = sender.fork_inside([&] { return send_one(sender.address(), "hello"); });
            EXPECT_EQ(wait_child(child), 0);
            report = read_within(got[0], 200ms);
            return !report.empty();
        },
        10s);

    EXPECT_TRUE(arrived);
    EXPECT_EQ(report, net.host(1).address() + " hello");
    EXPECT_EQ(wait_child(receiver), 0);
    ::close(ready[0]);
    ::close(got[0]);
}

TEST(Netns_test, NothingIsLeftAfterTheNetworkGoes) {
    PLEXUS_NEEDS_NETNS();
    std::vector<std::string> made;
    pid_t stray = -1;
    {
        Network net(4);
        made = net.namespaces();
        ASSERT_EQ(made.size(), 5u);
        const auto listed = list_namespaces();
        for (const auto& name : made)
            EXPECT_NE(std::find(listed.begin(), listed.end(), name), listed.end()) << name;
        // A process the test forgot, detached from the shell that started it: the network kills it.
        const std::string pid = net.host(2).run_checked("sleep 600 >/dev/null 2>&1 </dev/null & echo $!");
        stray = static_cast<pid_t>(std::stol(pid));
        ASSERT_TRUE(process_running(stray));
    }
    const auto listed = list_namespaces();
    for (const auto& name : made)
        EXPECT_EQ(std::find(listed.begin(), listed.end(), name), listed.end()) << name << " is still there";
    EXPECT_TRUE(eventually([&] { return !process_running(stray); }, 5s)) << "sleep " << stray << " survived";
}

TEST(Netns_test, NamespacesOfARunThatDiedAreRemoved) {
    PLEXUS_NEEDS_NETNS();
    // A pid that no process has any more: a child that has exited and been reaped.
    const pid_t dead = ::fork();
    ASSERT_GE(dead, 0);
    if (dead == 0)
        ::_exit(0);
    ASSERT_EQ(wait_child(dead), 0);
    const std::string stale = "plx" + std::to_string(dead) + "-0-h0";
    ASSERT_EQ(run_command({"ip", "netns", "add", stale}).status, 0);

    Network net(1);

    const auto listed = list_namespaces();
    EXPECT_EQ(std::find(listed.begin(), listed.end(), stale), listed.end());
    run_command({"ip", "netns", "delete", stale});  // in case it was not removed
}

TEST(Netns_test, TcpDeliversInOrderBetweenDaemonsOnTwoHosts) {
    PLEXUS_NEEDS_NETNS();
    Network net(4);
    TempDir dir;
    NameServerProcess names(dir, net.host(0));
    Daemon writer_side(dir, net.host(1), "one", names.address());
    Daemon reader_side(dir, net.host(2), "two", names.address());
    EXPECT_EQ(writer_side.address().rfind(net.host(1).address() + ":", 0), 0u) << writer_side.address();
    EXPECT_EQ(reader_side.address().rfind(net.host(2).address() + ":", 0), 0u) << reader_side.address();

    const int count = 200;
    auto reader = start_cli(dir, reader_side,
                            {"read", "/b/in", "--count", std::to_string(count), "--timeout", "60"}, "reader");
    ASSERT_TRUE(wait_port(dir, writer_side, "/b/in"));
    auto written = run_cli(dir, writer_side, {"write", "/a/out", "/b/in"}, numbered_lines(0, count));

    ASSERT_EQ(written.status, 0) << written.err;
    ASSERT_EQ(reader->wait(60s), 0) << reader->err();
    EXPECT_EQ(reader->out(), numbered_lines(0, count));
}

TEST(Netns_test, ARecvMonitorRunsOnAConnectionBetweenHosts) {
    PLEXUS_NEEDS_NETNS();
    Network net(4);
    TempDir dir;
    NameServerProcess names(dir, net.host(0));
    Daemon writer_side(dir, net.host(1), "one", names.address());
    Daemon plain_side(dir, net.host(2), "two", names.address());
    Daemon monitor_side(dir, net.host(3), "three", names.address(), {"--scripts", monitors_dir()});

    const int count = 50;
    auto plain = start_cli(dir, plain_side,
                           {"read", "/b/in", "--count", std::to_string(count), "--timeout", "60"}, "plain");
    // No --count: the monitor is asked about after the last message, and its connection (and the
    // monitor with it) goes away when either port closes.
    auto monitored = start_cli(dir, monitor_side, {"read", "/c/in", "--timeout", "60"}, "monitored");
    CliWriter writer(dir, writer_side, "/a/out", "writer");
    ASSERT_TRUE(wait_port(dir, writer_side, "/a/out"));
    ASSERT_TRUE(wait_port(dir, writer_side, "/b/in"));
    ASSERT_TRUE(wait_port(dir, writer_side, "/c/in"));
    auto to_plain = run_cli(dir, writer_side, {"connect", "/a/out", "/b/in", "tcp"});
    ASSERT_EQ(to_plain.status, 0) << to_plain.err;
    auto to_monitored = run_cli(
        dir, writer_side, {"connect", "/a/out", "/c/in", "tcp+recv.portmonitor+type.lua+file.rate_logger"});
    ASSERT_EQ(to_monitored.status, 0) << to_monitored.err;

    writer.send(numbered_lines(0, count));

    ASSERT_EQ(plain->wait(60s), 0) << plain->err();
    EXPECT_EQ(plain->out(), numbered_lines(0, count));
    ASSERT_TRUE(eventually([&] { return monitored->out() == numbered_lines(0, count); }, 30s))
        << monitored->out();
    // The monitor saw every message, in the daemon of the host it was meant for.
    auto param = run_cli(dir, monitor_side, {"param", "get", "/a/out", "/c/in"});
    ASSERT_EQ(param.status, 0) << param.err;
    const auto monitors = json::parse(param.out);
    ASSERT_EQ(monitors.size(), 1u) << param.out;
    EXPECT_EQ(monitors[0]["script"], "rate_logger");
    EXPECT_EQ(monitors[0]["side"], "recv");
    EXPECT_EQ(monitors[0]["param"]["messages"], count);
    EXPECT_EQ(writer.finish(), 0) << writer.process().err();
}

}  // namespace netns_test
}  // namespace plexus::test
