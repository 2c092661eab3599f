// Leaving at the worst moment: clients, daemons and name servers that go (kill -9, SIGTERM) while
// the daemon is in the middle of something. The daemon must always exit within its grace on
// SIGTERM, and otherwise stay responsive.

#include <gtest/gtest.h>

#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "harness.hpp"

namespace leaving_test {

using namespace plexus::test;

/// How long a SIGTERMed daemon may take: its 3 s grace for what is in flight, and some slack.
std::chrono::milliseconds exit_bound() {
    return slower(std::chrono::milliseconds(6000));
}

std::size_t port_count(const TempDir& dir, const Daemon& daemon) {
    auto listed = run_cli(dir, daemon, {"list", "--json"});
    if (listed.status != 0)
        return 0;
    auto json = nlohmann::json::parse(listed.out, nullptr, false);
    if (!json.is_object() || !json.contains("ports"))
        return 0;
    return json["ports"].size();
}

// A daemon with 30 reading clients gets SIGTERM while all its clients are killed: the clients'
// sessions erase their ports while shutdown is telling the name server about them. Shutdown once
// looped over the router's map across that wait and spun at 100% CPU for good (3 rounds in 6).
TEST(Leaving_test, ADaemonWhoseClientsAreKilledDuringShutdownStillExits) {
    constexpr int rounds = 6;
    constexpr int readers = 30;
    for (int round = 0; round < rounds; ++round) {
        SCOPED_TRACE("round " + std::to_string(round));
        TempDir dir;
        Daemon daemon(dir, "leaving");
        std::vector<std::unique_ptr<Process>> clients;
        for (int i = 0; i < readers; ++i) {
            const std::string port = "/leaving/reader" + std::to_string(i);
            clients.push_back(start_cli(dir, daemon, {"read", port}, "reader" + std::to_string(i)));
        }
        ASSERT_TRUE(eventually([&] { return port_count(dir, daemon) >= readers; }))
            << "the readers' ports were never all registered";
        daemon.process().signal(SIGTERM);
        for (auto& client : clients)
            client->signal(SIGKILL);
        const auto status = daemon.process().wait(exit_bound());
        ASSERT_TRUE(status.has_value()) << "plexusd did not exit within its grace after SIGTERM";
        EXPECT_EQ(*status, 0) << daemon.process().err();
        EXPECT_FALSE(std::filesystem::exists(daemon.socket())) << "the socket file stays after SIGTERM";
    }
}

/// CPU seconds the process has used (user + system), from /proc.
double cpu_seconds(pid_t pid) {
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    const auto after_name = text.rfind(')');
    if (after_name == std::string::npos)
        return -1;
    std::istringstream fields(text.substr(after_name + 2));
    std::string field;
    unsigned long long user = 0;
    unsigned long long system = 0;
    for (int i = 3; i <= 15 && fields >> field; ++i) {  // fields 14 and 15: utime, stime
        if (i == 14)
            user = std::stoull(field);
        if (i == 15)
            system = std::stoull(field);
    }
    return static_cast<double>(user + system) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

/// True once the process uses under 5% of a core over half a second (it is idle, not spinning).
bool settles(pid_t pid) {
    return eventually(
        [&] {
            const double before = cpu_seconds(pid);
            const auto start = std::chrono::steady_clock::now();
            while (std::chrono::steady_clock::now() - start < std::chrono::milliseconds(500)) {
                // Measuring an interval, not waiting for an event: nothing here can end it sooner.
                std::this_thread::sleep_for(std::chrono::milliseconds(50));
            }
            return cpu_seconds(pid) - before < 0.025;
        },
        20s);
}

// Clients killed (-9 and SIGTERM) in the middle of connect with a monitor, param set, disconnect
// and events --watch, a reader and the writer killed mid-stream: round after round the daemon
// answers, goes back to idle, and exits within its grace on SIGTERM.
TEST(Leaving_test, ClientsKilledInTheMiddleOfControlRequestsLeaveTheDaemonResponsiveAndStoppable) {
    constexpr int rounds = 5;
    const std::string carrier = "tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.5";
    for (int round = 0; round < rounds; ++round) {
        SCOPED_TRACE("round " + std::to_string(round));
        TempDir dir;
        Daemon daemon(dir, "leaving", "", {"--scripts", monitors_dir()});
        auto reader = start_cli(dir, daemon, {"read", "/leave/in"}, "reader");
        auto other = start_cli(dir, daemon, {"read", "/leave/other"}, "other");
        CliWriter writer(dir, daemon, "/leave/out", "writer");
        ASSERT_TRUE(wait_port(dir, daemon, "/leave/in") && wait_port(dir, daemon, "/leave/out") &&
                    wait_port(dir, daemon, "/leave/other"));
        ASSERT_EQ(run_cli(dir, daemon, {"connect", "/leave/out", "/leave/in", carrier}).status, 0);
        writer.send(numbered_lines(0, 200));

        // Each kind of request, started and killed at once: it dies somewhere in its request.
        const std::vector<std::vector<std::string>> requests{
            {"connect", "/leave/out", "/leave/other", carrier},
            {"param", "set", "/leave/out", "/leave/in", "threshold=0.7"},
            {"param", "get", "/leave/out", "/leave/in"},
            {"disconnect", "/leave/out", "/leave/other"},
            {"events", "/leave/in", "--watch", "--interval", "0.05"},
            {"stats", "--json"},
        };
        std::vector<std::unique_ptr<Process>> doomed;
        for (std::size_t i = 0; i < requests.size() * 3; ++i) {
            doomed.push_back(
                start_cli(dir, daemon, requests[i % requests.size()], "doomed" + std::to_string(i)));
            doomed.back()->signal(i % 2 == 0 ? SIGKILL : SIGTERM);
        }
        writer.send(numbered_lines(200, 200));
        other->signal(SIGKILL);
        writer.process().signal(SIGKILL);
        for (auto& process : doomed)
            process->wait(slower(10s));

        EXPECT_EQ(run_cli(dir, daemon, {"list"}, "", slower(10s)).status, 0)
            << "the daemon stopped answering";
        EXPECT_TRUE(settles(daemon.process().pid())) << "the daemon keeps using CPU with nothing to do";
        daemon.process().signal(SIGTERM);
        const auto status = daemon.process().wait(exit_bound());
        ASSERT_TRUE(status.has_value()) << "plexusd did not exit within its grace after SIGTERM";
        EXPECT_EQ(*status, 0);
    }
}

// The name server (embedded in another daemon) dies while a daemon makes connections through
// it: requests fail with a reason, the daemon stays responsive and stops on SIGTERM.
TEST(Leaving_test, ANameServerKilledInTheMiddleOfConnectsLeavesTheDaemonStoppable) {
    constexpr int rounds = 3;
    for (int round = 0; round < rounds; ++round) {
        SCOPED_TRACE("round " + std::to_string(round));
        TempDir dir;
        auto names = std::make_unique<NameServerProcess>(dir);
        Daemon daemon(dir, "orphan", names->address());
        auto reader = start_cli(dir, daemon, {"read", "/orphan/in"}, "reader");
        CliWriter writer(dir, daemon, "/orphan/out", "writer");
        ASSERT_TRUE(wait_port(dir, daemon, "/orphan/in") && wait_port(dir, daemon, "/orphan/out"));
        std::vector<std::unique_ptr<Process>> connects;
        for (int i = 0; i < 6; ++i)
            connects.push_back(start_cli(dir, daemon, {"connect", "/orphan/out", "/orphan/in"},
                                         "connect" + std::to_string(i)));
        names->process().signal(SIGKILL);
        for (auto& process : connects)
            EXPECT_TRUE(process->wait(slower(20s)).has_value()) << "a connect hung once the name server died";
        EXPECT_EQ(run_cli(dir, daemon, {"stats"}, "", slower(10s)).status, 0);
        EXPECT_TRUE(settles(daemon.process().pid()));
        daemon.process().signal(SIGTERM);
        const auto status = daemon.process().wait(exit_bound());
        ASSERT_TRUE(status.has_value()) << "plexusd did not exit within its grace after SIGTERM";
    }
}

// The daemon at the other end of connections is killed while they are being made, then comes
// back: the connecting daemon answers every request (an error that says why, or success), goes
// back to idle, and stops on SIGTERM. A client that closes its socket mid-request is a leaver too.
TEST(Leaving_test, APeerDaemonKilledInTheMiddleOfConnectsLeavesTheOtherStoppable) {
    TempDir dir;
    Daemon near(dir, "near");
    Daemon far(dir, "far", near.names());
    auto far_reader = start_cli(dir, far, {"read", "/far/in", "--timeout", "60"}, "far-reader");
    CliWriter writer(dir, near, "/near/out", "writer");
    ASSERT_TRUE(wait_port(dir, near, "/far/in") && wait_port(dir, near, "/near/out"));
    for (int round = 0; round < 3; ++round) {
        SCOPED_TRACE("round " + std::to_string(round));
        std::vector<std::unique_ptr<Process>> connects;
        for (int i = 0; i < 4; ++i) {
            connects.push_back(start_cli(dir, near, {"connect", "/near/out", "/far/in", "tcp"},
                                         "connect" + std::to_string(round) + "-" + std::to_string(i)));
        }
        // One client walks away from its request: its socket closes before the answer.
        start_cli(dir, near, {"disconnect", "/near/out", "/far/in"}, "walks-away" + std::to_string(round))
            ->signal(SIGTERM);
        far.process().signal(SIGKILL);
        for (auto& process : connects)
            EXPECT_TRUE(process->wait(slower(20s)).has_value()) << "a connect hung once its peer died";
        EXPECT_EQ(run_cli(dir, near, {"stats"}, "", slower(10s)).status, 0);
        far.start_again();
        far_reader =
            start_cli(dir, far, {"read", "/far/in", "--timeout", "60"}, "far-reader" + std::to_string(round));
        ASSERT_TRUE(wait_port(dir, near, "/far/in"));
    }
    EXPECT_TRUE(settles(near.process().pid()));
    near.process().signal(SIGTERM);
    const auto status = near.process().wait(exit_bound());
    ASSERT_TRUE(status.has_value()) << "plexusd did not exit within its grace after SIGTERM";
    EXPECT_EQ(*status, 0);
}

// `plexus up` killed (-9) part-way, round after round: the next `up` still applies the application
// (idempotent, whatever the last one left), `down` removes it, and the daemon stops on SIGTERM.
TEST(Leaving_test, UpKilledPartWayLeavesNothingTheNextUpAndDownCannotMend) {
    TempDir dir;
    Daemon daemon(dir, "apps");
    const std::string app = dir.file("app.json");
    // Readers that end by themselves: whatever a killed `up` started is gone when the test is.
    std::ofstream(app) << R"({"name": "leaving", "components": [
    {"name": "a", "command": "plexus", "args": ["read", "/up/a", "--timeout", "60"], "ports": ["/up/a"]},
    {"name": "b", "command": "plexus", "args": ["read", "/up/b", "--timeout", "60"], "ports": ["/up/b"]}],
  "connections": [{"source": "/up/a", "destination": "/up/b", "carrier": "tcp"}]})";
    for (int round = 0; round < 4; ++round) {
        auto up = start_cli(dir, daemon, {"up", app}, "up" + std::to_string(round));
        up->signal(SIGKILL);
        up->wait(slower(10s));
    }
    auto up = run_cli(dir, daemon, {"up", app}, "", slower(60s));
    EXPECT_EQ(up.status, 0) << up.err;
    EXPECT_EQ(run_cli(dir, daemon, {"exists", "/up/a", "/up/b"}).status, 0);
    auto down = run_cli(dir, daemon, {"down", app}, "", slower(60s));
    EXPECT_EQ(down.status, 0) << down.err;
    EXPECT_TRUE(settles(daemon.process().pid()));
    daemon.process().signal(SIGTERM);
    const auto status = daemon.process().wait(exit_bound());
    ASSERT_TRUE(status.has_value()) << "plexusd did not exit within its grace after SIGTERM";
    EXPECT_EQ(*status, 0);
    EXPECT_FALSE(std::filesystem::exists(daemon.socket())) << "the socket file stays after SIGTERM";
}

}  // namespace leaving_test
