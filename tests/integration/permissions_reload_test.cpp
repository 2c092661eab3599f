// SIGHUP reads the permissions file again: the new rules apply from the next request, a file that
// cannot be used leaves the old ones in force, and the daemon (and its embedded name server) go on.
#include <signal.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <fstream>

#include "harness.hpp"

namespace plexus::test {
namespace permissions_reload_test {

using nlohmann::json;

/// Rules that let this test's user (at the daemon) and its node (at the embedded name server, which
/// checks register_port) open, read, write and connect the ports under each prefix: two per prefix.
void write_rules(const std::string& path, const std::vector<std::string>& prefixes) {
    json rules = json::array();
    for (const auto& prefix : prefixes) {
        for (const auto& who : {json{{"users", {::getuid()}}}, json{{"nodes", {"node"}}}}) {
            json rule = who;
            rule["allow"] = {"open", "read", "write", "connect"};
            rule["ports"] = {prefix + "/*"};
            rules.push_back(rule);
        }
    }
    // Write then rename: the daemon never reads half a file.
    std::ofstream(path + ".tmp") << json{{"rules", rules}};
    std::filesystem::rename(path + ".tmp", path);
}

TEST(PermissionsReload_test, SighupAppliesTheNewRulesAndABrokenFileKeepsTheOld) {
    TempDir dir;
    const std::string rules = dir.file("permissions.json");
    write_rules(rules, {"/a"});
    Daemon daemon(dir, "node", "", {"--permissions", rules});
    const auto log = [&] { return daemon.process().out() + daemon.process().err(); };

    auto refused = run_cli(dir, daemon, {"write", "/b/out"}, "1\n");
    EXPECT_EQ(refused.status, 4) << refused.out;
    EXPECT_NE(refused.err.find("may not open /b/out"), std::string::npos) << refused.err;
    EXPECT_EQ(run_cli(dir, daemon, {"write", "/a/out"}, "1\n").status, 0);

    write_rules(rules, {"/a", "/b"});
    daemon.process().signal(SIGHUP);
    // The daemon's rules and the embedded name server's (it checks register_port): two lines, the
    // second logged just after the first.
    ASSERT_TRUE(eventually(
        [&] {
            const auto text = log();
            return text.find("SIGHUP: permissions reloaded from " + rules + ": 4 rules") !=
                       std::string::npos &&
                   text.find("names: SIGHUP: permissions reloaded") != std::string::npos;
        },
        20s))
        << log();
    auto allowed = run_cli(dir, daemon, {"write", "/b/out"}, "1\n");
    EXPECT_EQ(allowed.status, 0) << allowed.err;

    // A broken file: said, and the rules read before stay.
    { std::ofstream(rules) << "{\"rules\": [ not json"; }
    daemon.process().signal(SIGHUP);
    // (One line: waited for whole, the log may be read while it is written.)
    ASSERT_TRUE(eventually(
        [&] {
            const auto text = log();
            return text.find("SIGHUP: permissions not reloaded") != std::string::npos &&
                   text.find("the rules read before stay in force") != std::string::npos;
        },
        20s))
        << log();
    EXPECT_EQ(run_cli(dir, daemon, {"write", "/b/again"}, "1\n").status, 0);
    auto still_refused = run_cli(dir, daemon, {"write", "/c/out"}, "1\n");
    EXPECT_EQ(still_refused.status, 4) << still_refused.out;
    EXPECT_TRUE(daemon.process().running());
}

TEST(PermissionsReload_test, ANameServerOfItsOwnReloadsOnSighupToo) {
    TempDir dir;
    const std::string rules = dir.file("names-permissions.json");
    write_rules(rules, {"/a"});
    NameServerProcess names(dir, {"--permissions", rules});
    Daemon daemon(dir, "node", names.address());
    const auto log = [&] { return names.process().out() + names.process().err(); };

    // The name server refuses to register what no rule lets the node open: the CLI is told.
    auto refused = run_cli(dir, daemon, {"write", "/b/out"}, "1\n");
    EXPECT_EQ(refused.status, 4) << refused.out;
    EXPECT_NE(refused.err.find("may not open /b/out"), std::string::npos) << refused.err;

    write_rules(rules, {"/a", "/b"});
    names.process().signal(SIGHUP);
    ASSERT_TRUE(eventually(
        [&] { return log().find("names: SIGHUP: permissions reloaded from " + rules) != std::string::npos; },
        20s))
        << log();
    auto allowed = run_cli(dir, daemon, {"write", "/b/out"}, "1\n");
    EXPECT_EQ(allowed.status, 0) << allowed.err;
    EXPECT_TRUE(names.process().running());
}

}  // namespace permissions_reload_test
}  // namespace plexus::test
