// What the name server must know of the daemons, whatever happened to it or how they listen: the
// connections they carry after it restarted without a state file, an address other hosts can
// reach for a daemon listening on every interface, and a clear refusal of a taken node name.
#include <signal.h>

#include <gtest/gtest.h>

#include <filesystem>

#include "harness.hpp"
#include "netns.hpp"

namespace plexus::test {
namespace names_registrations_test {

using nlohmann::json;

json listed(const TempDir& dir, const Daemon& daemon) {
    auto list = run_cli(dir, daemon, {"list", "--json"}, "", 10s);
    return list.status == 0 ? json::parse(list.out, nullptr, false) : json();
}

bool lists_connection(const TempDir& dir, const Daemon& daemon, const std::string& source,
                      const std::string& destination) {
    const auto list = listed(dir, daemon);
    if (!list.is_object())
        return false;
    for (const auto& c : list["connections"]) {
        if (c["source"] == source && c["destination"] == destination)
            return true;
    }
    return false;
}

// A name server restarted without --state knew none of the live connections: `list` showed none,
// `exists SRC DST` said no while data flowed, and `plexus up` failed on "already connected".
TEST(NamesRegistrations_test, ANameServerRestartedWithoutStateLearnsTheLiveConnectionsAgain) {
    TempDir dir;
    auto names = std::make_unique<NameServerProcess>(dir);
    const std::string where = names->address();
    Daemon daemon(dir, "one", where);
    auto reader = start_cli(dir, daemon, {"read", "/b/in", "--timeout", "120"}, "reader");
    CliWriter writer(dir, daemon, "/a/out", "writer");
    ASSERT_TRUE(wait_port(dir, daemon, "/b/in") && wait_port(dir, daemon, "/a/out"));
    auto connected = run_cli(dir, daemon, {"connect", "/a/out", "/b/in"});
    ASSERT_EQ(connected.status, 0) << connected.err;
    ASSERT_TRUE(lists_connection(dir, daemon, "/a/out", "/b/in"));

    names->process().signal(SIGKILL);
    ASSERT_TRUE(names->process().wait(10s).has_value());
    const std::string ready = dir.file("names-again.ready");
    Process again({names_path(), "--listen", where, "--ready-file", ready}, {}, dir.file("names-again"));
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(ready); }, 20s)) << again.err();

    EXPECT_TRUE(eventually([&] { return lists_connection(dir, daemon, "/a/out", "/b/in"); }, 20s))
        << listed(dir, daemon).dump();
    EXPECT_EQ(run_cli(dir, daemon, {"exists", "/a/out", "/b/in"}).status, 0);
    writer.send("1\n");
    EXPECT_TRUE(eventually([&] { return reader->out() == "1\n"; })) << reader->err();
}

// A second daemon that takes a node name a running daemon holds is told so, says so, and exits:
// it used to stay up, refused every 2 s, while its clients heard "the name server is not reachable".
TEST(NamesRegistrations_test, ADaemonWhoseNodeNameIsTakenSaysSoAndExits) {
    TempDir dir;
    NameServerProcess names(dir);
    Daemon first(dir, "taken", names.address());
    Process second({plexusd_path(), "--node", "taken", "--socket", dir.file("second.sock"), "--listen",
                    "127.0.0.1:0", "--names", names.address()},
                   {}, dir.file("second"));
    const auto status = second.wait(slower(10s));
    ASSERT_TRUE(status.has_value()) << "the second daemon is still running";
    EXPECT_EQ(*status, 4);
    const std::string said = second.out() + second.err();  // spdlog writes to standard output
    EXPECT_NE(said.find("already registered"), std::string::npos) << said;
    EXPECT_FALSE(std::filesystem::exists(dir.file("second.sock"))) << "its socket file was left behind";
    // The first daemon is unharmed.
    EXPECT_EQ(run_cli(dir, first, {"list"}).status, 0);
}

// A daemon listening on 0.0.0.0 registered its ports at 0.0.0.0:PORT, and every other host got
// "cannot connect to 0.0.0.0:PORT". The name server records where its session came from.
TEST(NamesRegistrations_test, ADaemonListeningOnEveryInterfaceIsReachedFromAnotherHost) {
    PLEXUS_NEEDS_NETNS();
    Network net(2);
    TempDir dir;
    NameServerProcess names(dir, net.host(0));
    Daemon writer_side(dir, net.host(0), "writer-side", names.address());

    // The reader's daemon, on host 1, listening on every interface.
    const std::string ready = dir.file("wildcard.ready");
    const std::string socket = dir.file("wildcard.sock");
    std::vector<std::string> argv{plexusd_path(),  "--node",       "wildcard",  "--socket",
                                  socket,          "--listen",     "0.0.0.0:0", "--names",
                                  names.address(), "--ready-file", ready};
    const auto& flags = beyond_loopback_flags();
    argv.insert(argv.end(), flags.begin(), flags.end());
    Process wildcard(net.host(1).wrap(argv), {}, dir.file("wildcard"));
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(ready); }, 20s)) << wildcard.err();

    std::map<std::string, std::string> reader_env{{"PLEXUS_SOCKET", socket},
                                                  {"PLEXUS_NAMES", names.address()},
                                                  {"PLEXUS_SECRET_FILE", test_secret_file()}};
    Process reader(net.host(1).wrap({plexus_path(), "read", "/far/in", "--count", "1", "--timeout", "60"}),
                   reader_env, dir.file("reader"));
    ASSERT_TRUE(wait_port(dir, writer_side, "/far/in"));

    std::string address;
    const json list = listed(dir, writer_side);
    for (const auto& port : list["ports"]) {
        if (port["name"] == "/far/in")
            address = port["address"];
    }
    EXPECT_EQ(address.rfind(net.host(1).address() + ":", 0), 0u)
        << "/far/in is listed at " << address << ": " << list.dump();

    auto written = run_cli(dir, writer_side, {"write", "/near/out", "/far/in"}, "\"across\"\n");
    ASSERT_EQ(written.status, 0) << written.err;
    ASSERT_EQ(reader.wait(slower(30s)), 0) << reader.err();
    EXPECT_EQ(reader.out(), "\"across\"\n");
}

}  // namespace names_registrations_test
}  // namespace plexus::test
