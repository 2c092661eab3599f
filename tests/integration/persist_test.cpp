// Persistent connections: remembered by the name server, made again when their ports return,
// and kept across a name-server restart in its state file.
#include <gtest/gtest.h>

#include <filesystem>

#include "harness.hpp"

namespace plexus::test {
namespace persist_test {

bool connection_listed(const TempDir& dir, const Daemon& daemon, const std::string& state) {
    auto list = run_cli(dir, daemon, {"list", "--json"});
    if (list.status != 0)
        return false;
    const auto listed = nlohmann::json::parse(list.out);  // named: a temporary would dangle in the loop
    for (const auto& c : listed["connections"]) {
        if (c["source"] == "/src" && c["destination"] == "/sink" && c["persistent"] == true &&
            c["live"] == (state == "up")) {
            return true;
        }
    }
    return false;
}

TEST(Persist_test, APersistentConnectionComesBackWithItsPorts) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", {"--names-state", dir.file("names.json")});
    {
        auto sink = start_cli(dir, daemon, {"read", "/sink", "--timeout", "30"}, "sink1");
        auto source = start_cli(dir, daemon, {"read", "/src", "--timeout", "30"}, "src1");
        ASSERT_TRUE(wait_port(dir, daemon, "/sink"));
        ASSERT_TRUE(wait_port(dir, daemon, "/src"));
        ASSERT_EQ(run_cli(dir, daemon, {"connect", "/src", "/sink", "--persist"}).status, 0);
        EXPECT_TRUE(connection_listed(dir, daemon, "up"));
    }  // both ports go away
    ASSERT_TRUE(eventually([&] { return connection_listed(dir, daemon, "waiting"); }));

    auto sink = start_cli(dir, daemon, {"read", "/sink", "--count", "2", "--timeout", "30"}, "sink2");
    ASSERT_TRUE(wait_port(dir, daemon, "/sink"));
    auto written = run_cli(dir, daemon, {"write", "/src"}, "1\n2\n");  // no DST: the remembered one

    ASSERT_EQ(written.status, 0) << written.err;
    ASSERT_EQ(sink->wait(30s), 0) << sink->err();
    EXPECT_EQ(sink->out(), "1\n2\n");
}

TEST(Persist_test, TheNameServerKeepsPersistentConnectionsAcrossARestart) {
    TempDir dir;
    const std::string state = dir.file("names.json");
    const std::string ready = dir.file("names.ready");
    auto names = std::make_unique<Process>(std::vector<std::string>{names_path(), "--listen", "127.0.0.1:0",
                                                                    "--state", state, "--ready-file", ready},
                                           std::map<std::string, std::string>{}, dir.file("names1"));
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(ready); }));
    const std::string where = nlohmann::json::parse(read_file(ready))["names"];
    {
        Daemon daemon(dir, "worker", where);
        auto sink = start_cli(dir, daemon, {"read", "/sink", "--timeout", "30"}, "sink");
        auto source = start_cli(dir, daemon, {"read", "/src", "--timeout", "30"}, "src");
        ASSERT_TRUE(wait_port(dir, daemon, "/sink") && wait_port(dir, daemon, "/src"));
        ASSERT_EQ(run_cli(dir, daemon, {"connect", "/src", "/sink", "--persist"}).status, 0);
    }
    names.reset();  // SIGTERM, waited for
    std::filesystem::remove(ready);
    names = std::make_unique<Process>(
        std::vector<std::string>{names_path(), "--listen", where, "--state", state, "--ready-file", ready},
        std::map<std::string, std::string>{}, dir.file("names2"));
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(ready); }));

    Daemon daemon(dir, "again", where);
    EXPECT_TRUE(connection_listed(dir, daemon, "waiting"));
    auto disconnected = run_cli(dir, daemon, {"disconnect", "/src", "/sink"});
    EXPECT_EQ(disconnected.status, 4) << "disconnect needs the source port to exist: " << disconnected.err;
}

}  // namespace persist_test
}  // namespace plexus::test
