// A name server that dies (kill -9) and comes back, on separate hosts: data between the daemons
// never needed it, so nothing is lost; the daemons register again by themselves and persistent
// connections return from its state file.
#include <signal.h>

#include <gtest/gtest.h>

#include <filesystem>

#include "harness.hpp"
#include "netns.hpp"

namespace plexus::test {
namespace names_restart_test {

using nlohmann::json;

bool registered_again(const TempDir& dir, const Daemon& daemon) {
    auto list = run_cli(dir, daemon, {"list", "--json"}, "", 10s);
    if (list.status != 0)
        return false;
    const auto listed = json::parse(list.out);
    bool ports = false;
    bool persistent = false;
    int found = 0;
    for (const auto& port : listed["ports"])
        found += port["name"] == "/a/out" || port["name"] == "/b/in";
    ports = found == 2;
    for (const auto& c : listed["connections"])
        persistent =
            persistent || (c["source"] == "/a/out" && c["destination"] == "/b/in" && c["persistent"] == true);
    return ports && persistent;
}

TEST(NamesRestart_test, KillingTheNameServerLosesNoDataAndRegistrationsReturn) {
    PLEXUS_NEEDS_NETNS();
    Network net(3);
    TempDir dir;
    const std::string state = dir.file("names-state.json");
    auto names =
        std::make_unique<NameServerProcess>(dir, net.host(0), std::vector<std::string>{"--state", state});
    const std::string where = names->address();
    Daemon writer_side(dir, net.host(1), "one", where);
    Daemon reader_side(dir, net.host(2), "two", where);
    const int part = 100;
    auto reader =
        start_cli(dir, reader_side,
                  {"read", "/b/in", "--count", std::to_string(3 * part), "--timeout", "120"}, "cli-reader");
    CliWriter writer(dir, writer_side, "/a/out", "cli-writer");
    ASSERT_TRUE(wait_port(dir, writer_side, "/b/in") && wait_port(dir, writer_side, "/a/out"));
    auto connected = run_cli(dir, writer_side, {"connect", "/a/out", "/b/in", "tcp", "--persist"});
    ASSERT_EQ(connected.status, 0) << connected.err;
    writer.send(numbered_lines(0, part));
    ASSERT_TRUE(eventually([&] { return reader->out() == numbered_lines(0, part); }, 30s)) << reader->out();

    names->process().signal(SIGKILL);
    ASSERT_TRUE(names->process().wait(10s).has_value());
    // With no name server at all, the connection carries on.
    writer.send(numbered_lines(part, part));
    ASSERT_TRUE(eventually([&] { return reader->out() == numbered_lines(0, 2 * part); }, 30s))
        << reader->out();

    // The same address and state file again: the daemons come back to it by themselves.
    const std::string ready = dir.file("names-again.ready");
    std::vector<std::string> argv{names_path(), "--listen", where, "--state", state, "--ready-file", ready};
    const auto& flags = beyond_loopback_flags();
    argv.insert(argv.end(), flags.begin(), flags.end());
    Process again(net.host(0).wrap(argv), {}, dir.file("names-again"));
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(ready); }, 20s)) << again.err();
    EXPECT_TRUE(eventually([&] { return registered_again(dir, writer_side); }, 30s))
        << run_cli(dir, writer_side, {"list", "--json"}).out;

    writer.send(numbered_lines(2 * part, part));
    ASSERT_EQ(reader->wait(60s), 0) << reader->err();
    EXPECT_EQ(reader->out(), numbered_lines(0, 3 * part));  // in order, nothing lost, nothing twice
    EXPECT_EQ(writer.finish(), 0) << writer.process().err();
}

}  // namespace names_restart_test
}  // namespace plexus::test
