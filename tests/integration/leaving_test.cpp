// Leaving at the worst moment: clients, daemons and name servers that go (kill -9, SIGTERM) while
// the daemon is in the middle of something. The daemon must always exit within its grace on
// SIGTERM, and otherwise stay responsive.

#include <gtest/gtest.h>

#include <csignal>
#include <memory>
#include <string>
#include <vector>

#include "harness.hpp"

namespace {

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
    }
}

}  // namespace
