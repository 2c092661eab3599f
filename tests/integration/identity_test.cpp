// Identities (issue 32, docs/SECURITY.md "Identities"): a deployment CA made with `plexus pki`, a
// name server and two daemons on their own hosts, each with its certificate. Data flows between
// them; a node can act only as the node its certificate names, at its own start, at the name
// server and on a link; a revoked certificate is refused from the next handshake on.
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "harness.hpp"
#include "netns.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace identity_test {

using nlohmann::json;

/// Runs `plexus pki ARGS...` (files only: no daemon, no host); its result.
CliResult pki(const TempDir& dir, const std::vector<std::string>& args) {
    std::vector<std::string> argv{plexus_path(), "pki"};
    argv.insert(argv.end(), args.begin(), args.end());
    static int runs = 0;
    Process process(argv, {}, dir.file("pki-" + std::to_string(++runs)));
    const auto status = process.wait(30s);
    return {status.value_or(-1), process.out(), process.err()};
}

/// The CA, a name server's identity and the nodes', made by the CLI as a person would.
class Identity_test : public ::testing::Test {
protected:
    void SetUp() override {
        PLEXUS_NEEDS_NETNS();
        net = std::make_unique<Network>(4);
        ASSERT_EQ(pki(dir, {"init", ca()}).status, 0);
        ASSERT_EQ(pki(dir, {"issue", "names0", "--names", "--ca", ca()}).status, 0);
        for (const std::string node : {"alpha", "beta", "arm", "planner"}) {
            const auto issued = pki(dir, {"issue", node, "--ca", ca()});
            ASSERT_EQ(issued.status, 0) << issued.err;
        }
        names = std::make_unique<NameServerProcess>(dir, net->host(0),
                                                    std::vector<std::string>{"--identity", names_identity()});
    }
    std::string ca() const { return dir.file("ca"); }
    std::string identity(const std::string& node) const { return ca() + "/nodes/" + node; }
    std::string names_identity() const { return ca() + "/names/names0"; }
    std::unique_ptr<Daemon> daemon(int host, const std::string& node, std::vector<std::string> extra = {}) {
        extra.insert(extra.end(), {"--identity", identity(node)});
        return std::make_unique<Daemon>(dir, net->host(host), node, names->address(), extra);
    }
    /// beta's reader of /beta/in, alpha's writer of /alpha/out, connected: true when a line crossed.
    bool line_crosses(Daemon& alpha, Daemon& beta, const std::string& line) {
        auto reader =
            start_cli(dir, beta, {"read", "/beta/in", "--timeout", "30", "--count", "1"}, "reader-" + line);
        if (!wait_port(dir, beta, "/beta/in"))
            return false;
        CliWriter writer(dir, alpha, "/alpha/out", "writer-" + line);
        if (!wait_port(dir, alpha, "/alpha/out"))
            return false;
        const auto connected = run_cli(dir, alpha, {"connect", "/alpha/out", "/beta/in"});
        if (connected.status != 0) {
            ADD_FAILURE() << connected.err;
            return false;
        }
        writer.send(line + "\n");
        const bool read = reader->wait(30s) == 0 && reader->out().find(line) != std::string::npos;
        writer.finish();
        return read;
    }

    TempDir dir;
    std::unique_ptr<Network> net;
    std::unique_ptr<NameServerProcess> names;
};

TEST_F(Identity_test, EachNodeActsOnlyAsTheNodeItsCertificateNames) {
    // The files a person gets: keys only their owner may read.
    struct stat key {};
    ASSERT_EQ(::stat((identity("alpha") + "/node.key").c_str(), &key), 0);
    EXPECT_EQ(key.st_mode & 0777, 0600u);
    ASSERT_EQ(::stat((ca() + "/ca.key").c_str(), &key), 0);
    EXPECT_EQ(key.st_mode & 0777, 0600u);

    auto alpha = daemon(1, "alpha");
    auto beta = daemon(2, "beta");
    EXPECT_TRUE(line_crosses(*alpha, *beta, "\"across\""));

    // A daemon started as another node than its certificate's refuses to start, and says why.
    const auto& outsider = net->host(3);
    Process claiming(outsider.wrap({plexusd_path(), "--listen", outsider.address() + ":0", "--names",
                                    names->address(), "--socket", dir.file("claim.sock"), "--node", "beta",
                                    "--secret-file", test_secret_file(), "--identity", identity("alpha")}),
                     {}, dir.file("claiming"));
    EXPECT_EQ(claiming.wait(30s), 2);
    EXPECT_NE(claiming.err().find("is that of node 'alpha'"), std::string::npos) << claiming.err();

    // Asked straight, with alpha's certificate, to register node beta (moving beta's address and
    // ports to the asker): the name server refuses and counts it.
    const auto child = outsider.fork_inside([&] {
        ::setenv("PLEXUS_SECRET_FILE", test_secret_file().c_str(), 1);
        ::setenv("PLEXUS_IDENTITY", identity("alpha").c_str(), 1);
        try {
            Client::ask_names(
                names->address(),
                json{{"op", "register_node"}, {"node", "beta"}, {"address", outsider.address() + ":1"}});
            return 1;
        } catch (const Error& e) {
            const std::string why = e.what();
            return e.code() == ErrorCode::refused &&
                           why.find("only be registered with its own certificate") != std::string::npos
                       ? 0
                       : 2;
        }
    });
    EXPECT_EQ(wait_child(child), 0);
    EXPECT_NE(names->process().out().find("refused to register node 'beta'"), std::string::npos)
        << names->process().out();
    // beta is still where it was, and still reachable.
    auto listed = run_cli(dir, *alpha, {"list", "--json"});
    ASSERT_EQ(listed.status, 0) << listed.err;
    EXPECT_EQ(listed.out.find(outsider.address() + ":1"), std::string::npos) << listed.out;

    // A CLI with only the secret cannot talk to a deployment of identities.
    Process secret_only(outsider.wrap({plexus_path(), "--names", names->address(), "--secret-file",
                                       test_secret_file(), "list"}),
                        {}, dir.file("secret-only"));
    EXPECT_EQ(secret_only.wait(30s), 4);
}

TEST_F(Identity_test, ARevokedNodeLosesItsOpenLinksAndIsRefusedFromItsNextHandshakeOn) {
    auto alpha = daemon(1, "alpha");
    auto beta = daemon(2, "beta");
    ASSERT_TRUE(line_crosses(*alpha, *beta, "\"before\""));
    // (the writer closed /alpha/out: the connection went with it)

    auto reader = start_cli(dir, *beta, {"read", "/beta/in", "--timeout", "60"}, "reader-after");
    ASSERT_TRUE(wait_port(dir, *beta, "/beta/in"));
    // A link made before the revocation: a stream from alpha into beta, flowing.
    auto live_reader = start_cli(dir, *beta, {"read", "/beta/live", "--timeout", "60"}, "live-reader");
    ASSERT_TRUE(wait_port(dir, *beta, "/beta/live"));
    CliWriter live(dir, *alpha, "/alpha/live", "live-writer");
    ASSERT_TRUE(wait_port(dir, *alpha, "/alpha/live"));
    ASSERT_EQ(run_cli(dir, *alpha, {"connect", "/alpha/live", "/beta/live"}).status, 0);
    live.send("\"flowing\"\n");
    ASSERT_TRUE(eventually([&] { return live_reader->out().find("flowing") != std::string::npos; }, 30s));

    const auto revoked = pki(dir, {"revoke", "beta", "--ca", ca()});
    ASSERT_EQ(revoked.status, 0) << revoked.err;

    // The link open before goes within seconds: alpha finds beta's certificate on the new list.
    EXPECT_TRUE(eventually(
        [&] {
            const auto log = alpha->process().out() + alpha->process().err();
            return log.find("the certificate of node 'beta' was revoked after this link was made") !=
                   std::string::npos;
        },
        30s))
        << alpha->process().out() << alpha->process().err();

    // alpha will not link to beta any more: beta's certificate is on the list alpha reads.
    CliWriter writer(dir, *alpha, "/alpha/out", "writer-after");
    ASSERT_TRUE(wait_port(dir, *alpha, "/alpha/out"));
    const auto connected = run_cli(dir, *alpha, {"connect", "/alpha/out", "/beta/in"});
    EXPECT_EQ(connected.status, 4) << connected.out;
    EXPECT_NE(connected.err.find("certificate revoked"), std::string::npos) << connected.err;

    // A CLI with beta's identity: the name server refuses it (exit 4, the reason said).
    Process asked(net->host(2).wrap({plexus_path(), "--names", names->address(), "list"}), beta->env(),
                  dir.file("revoked-cli"));
    EXPECT_EQ(asked.wait(30s), 4);
    EXPECT_NE(asked.err().find("certificate revoked"), std::string::npos) << asked.err();

    // And beta's daemon, started again, cannot register.
    beta->process().signal(SIGKILL);
    beta->process().wait(10s);
    const auto& host = net->host(2);
    Process again(host.wrap({plexusd_path(), "--listen", host.address() + ":0", "--names", names->address(),
                             "--socket", dir.file("again.sock"), "--secret-file", test_secret_file(),
                             "--identity", identity("beta")}),
                  {}, dir.file("again"));
    EXPECT_TRUE(eventually(
        [&] {
            const auto log = again.out() + again.err();
            return log.find("name server") != std::string::npos && log.find("revoked") != std::string::npos;
        },
        30s))
        << again.out() << again.err();

    // alpha and the name server carry on with each other.
    EXPECT_EQ(run_cli(dir, *alpha, {"list"}).status, 0);
}

TEST_F(Identity_test, ANodeWithAValidCertificateButNoPermissionToWriteIsRefusedAndNothingChanges) {
    // The arm's daemon: the arm itself may do anything with its ports, the planner may write its
    // commands, anyone may read its state; its local components (this test's user) may open and
    // read its ports, and nothing else.
    const std::string permissions = dir.file("arm-permissions.json");
    std::ofstream(permissions) << json{
        {"rules",
         {{{"nodes", {"arm"}},
           {"allow", {"open", "read", "write", "connect", "monitor"}},
           {"ports", {"/arm/**"}}},
          {{"nodes", {"planner"}}, {"allow", {"write"}}, {"ports", {"/arm/cmd"}}},
          {{"nodes", {"*"}}, {"allow", {"read"}}, {"ports", {"/arm/state"}}},
          {{"users", {::getuid()}}, {"allow", {"open", "read", "connect"}}, {"ports", {"/arm/*"}}},
          {{"users", {::getuid()}}, {"allow", {"open", "read", "write", "connect"}}, {"ports", {"/ui/*"}}}}}};
    auto arm = daemon(1, "arm", {"--permissions", permissions});
    auto beta = daemon(2, "beta");
    auto planner = daemon(3, "planner");
    auto reader = start_cli(dir, *arm, {"read", "/arm/cmd", "--timeout", "60"}, "arm-reader");
    ASSERT_TRUE(wait_port(dir, *arm, "/arm/cmd"));

    // beta holds a valid certificate, but no permission to write /arm/cmd: exit 4, and why.
    auto intruder = run_cli(dir, *beta, {"write", "/beta/out", "/arm/cmd"}, "\"move\"\n");
    EXPECT_EQ(intruder.status, 4) << intruder.out;
    EXPECT_NE(intruder.err.find("node 'beta' may not write /arm/cmd"), std::string::npos) << intruder.err;
    // Nothing changed: no connection into /arm/cmd, nothing read, the refusal counted once each.
    auto listed = run_cli(dir, *arm, {"list", "--json"});
    ASSERT_EQ(listed.status, 0) << listed.err;
    EXPECT_EQ(json::parse(listed.out)["connections"].size(), 0u) << listed.out;
    auto stats = json::parse(run_cli(dir, *arm, {"stats", "--json"}).out);
    EXPECT_GE(stats["daemon"]["permission_refusals"].get<int>(), 1) << stats.dump();
    EXPECT_EQ(reader->out(), "");

    // The planner may: its command arrives.
    auto planned = run_cli(dir, *planner, {"write", "/planner/out", "/arm/cmd"}, "\"plan\"\n");
    EXPECT_EQ(planned.status, 0) << planned.err;
    EXPECT_TRUE(eventually([&] { return reader->out().find("plan") != std::string::npos; }, 30s))
        << reader->out();
    EXPECT_EQ(reader->out().find("move"), std::string::npos) << reader->out();

    // A local component may open the arm's ports but not one the rules do not name.
    auto opened = run_cli(dir, *arm, {"read", "/other/port", "--timeout", "1"});
    EXPECT_EQ(opened.status, 4);
    EXPECT_NE(opened.err.find("user " + std::to_string(::getuid()) + " may not open /other/port"),
              std::string::npos)
        << opened.err;
    // A local component connects two ports the rules give it, even over tcp (the link is the
    // daemon's own: checked when it was asked for), but not into the arm's commands.
    auto panel = start_cli(dir, *arm, {"read", "/ui/panel", "--timeout", "60"}, "ui-panel");
    ASSERT_TRUE(wait_port(dir, *arm, "/ui/panel"));
    CliWriter buttons(dir, *arm, "/ui/buttons", "ui-buttons");
    ASSERT_TRUE(wait_port(dir, *arm, "/ui/buttons"));
    const auto wired = run_cli(dir, *arm, {"connect", "/ui/buttons", "/ui/panel", "tcp"});
    EXPECT_EQ(wired.status, 0) << wired.err;
    const auto into_commands = run_cli(dir, *arm, {"connect", "/ui/buttons", "/arm/cmd"});
    EXPECT_EQ(into_commands.status, 4);
    EXPECT_NE(into_commands.err.find("user " + std::to_string(::getuid()) + " may not write /arm/cmd"),
              std::string::npos)
        << into_commands.err;

    // The refusal is in the daemon's log once, however often it is tried.
    run_cli(dir, *beta, {"write", "/beta/out", "/arm/cmd"}, "\"again\"\n");
    const auto log = arm->process().out() + arm->process().err();
    const std::string line = "refused: node 'beta' may not write /arm/cmd";
    const auto first = log.find(line);
    EXPECT_NE(first, std::string::npos) << log;
    EXPECT_EQ(log.find(line, first + 1), std::string::npos) << log;
}

}  // namespace identity_test
}  // namespace plexus::test
