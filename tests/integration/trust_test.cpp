// The deployment secret on separate hosts (network namespaces): what a host without it cannot do,
// and servers that will not listen beyond loopback without one.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "harness.hpp"
#include "netns.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/hello.hpp"

namespace plexus::test {
namespace trust_test {

using nlohmann::json;

/// Inside the calling namespace: connects to `address` as a link of node `node` with no secret,
/// asks to attach `source` to `destination`, and reads until the daemon closes. Exit 0 when it was
/// refused for want of the secret (an error frame saying so, and no reply), else 1.
int forge_attach(const std::string& address, const std::string& node, const std::string& source,
                 const std::string& destination) {
    const auto colon = address.rfind(':');
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<std::uint16_t>(std::stoi(address.substr(colon + 1))));
    ::inet_pton(AF_INET, address.substr(0, colon).c_str(), &to.sin_addr);
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0)
        return 2;
    proto::Bytes out = proto::encode_hello({proto::protocol_version, "link", node});
    const auto attach = proto::encode_request(
        {1, {{"op", "attach"}, {"source", source}, {"destination", destination}, {"carrier", "tcp"}}});
    out.insert(out.end(), attach.begin(), attach.end());
    if (::write(fd, out.data(), out.size()) != static_cast<ssize_t>(out.size()))
        return 3;
    std::string received;
    char buffer[4096];
    for (;;) {
        pollfd ready{fd, POLLIN, 0};
        if (::poll(&ready, 1, 20000) <= 0)
            return 4;
        const ssize_t n = ::read(fd, buffer, sizeof buffer);
        if (n <= 0)
            break;
        received.append(buffer, static_cast<std::size_t>(n));
    }
    const bool refused = received.find("authentication required") != std::string::npos;
    const bool answered = received.find("warnings") != std::string::npos;  // an attach reply
    return refused && !answered ? 0 : 1;
}

class Trust_test : public ::testing::Test {
protected:
    void SetUp() override {
        PLEXUS_NEEDS_NETNS();
        net = std::make_unique<Network>(4);
    }
    std::unique_ptr<Network> net;
    TempDir dir;
};

TEST_F(Trust_test, ServersRefuseToListenBeyondLoopbackWithoutASecretUnlessInsecure) {
    const auto& host = net->host(1);
    const std::string listen = host.address() + ":0";
    Process daemon(host.wrap({plexusd_path(), "--listen", listen, "--embedded-names", "--names", listen,
                              "--socket", dir.file("d.sock"), "--node", "d"}),
                   {}, dir.file("daemon"));
    EXPECT_EQ(daemon.wait(20s), 2);
    EXPECT_NE(daemon.err().find("will not listen on " + host.address() + " without a deployment secret"),
              std::string::npos)
        << daemon.err();
    Process names(host.wrap({names_path(), "--listen", listen}), {}, dir.file("names"));
    EXPECT_EQ(names.wait(20s), 2);
    EXPECT_NE(names.err().find("--secret-file"), std::string::npos) << names.err();

    // With --insecure it runs, and says so loudly.
    const std::string ready = dir.file("insecure.ready");
    Process insecure(host.wrap({names_path(), "--listen", listen, "--insecure", "--ready-file", ready}), {},
                     dir.file("insecure"));
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(ready); }, 20s)) << insecure.err();
    EXPECT_NE((insecure.out() + insecure.err()).find("INSECURE"), std::string::npos);

    // A secret file that others may read is refused too.
    const std::string open_secret = dir.file("open-secret");
    std::ofstream(open_secret) << "a-secret-long-enough-to-be-used";
    ::chmod(open_secret.c_str(), 0644);
    Process careless(
        host.wrap({names_path(), "--listen", host.address() + ":0", "--secret-file", open_secret}), {},
        dir.file("careless"));
    EXPECT_EQ(careless.wait(20s), 2);
    EXPECT_NE(careless.err().find("readable by others"), std::string::npos) << careless.err();
}

TEST_F(Trust_test, AHostWithoutTheSecretCannotAskRegisterConnectOrForgeAnAttach) {
    NameServerProcess names(dir, net->host(0));
    Daemon one(dir, net->host(1), "one", names.address());
    auto reader = start_cli(dir, one, {"read", "/one/in", "--timeout", "60"}, "reader");
    ASSERT_TRUE(wait_port(dir, one, "/one/in"));
    const auto& outsider = net->host(3);

    // The CLI with no secret, and with another one: refused, exit 4, with the reason.
    Process asked(outsider.wrap({plexus_path(), "--names", names.address(), "list"}), {}, dir.file("asked"));
    EXPECT_EQ(asked.wait(30s), 4);
    EXPECT_NE(asked.err().find("authentication required"), std::string::npos) << asked.err();
    const std::string wrong = dir.file("wrong-secret");
    std::ofstream(wrong) << "not-the-deployment-secret-at-all";
    ::chmod(wrong.c_str(), 0600);
    Process guessed(
        outsider.wrap({plexus_path(), "--names", names.address(), "--secret-file", wrong, "list"}), {},
        dir.file("guessed"));
    EXPECT_EQ(guessed.wait(30s), 4);
    EXPECT_NE(guessed.err().find("TLS handshake with " + names.address() + " failed"), std::string::npos)
        << guessed.err();
    EXPECT_NE(guessed.err().find("does not hold this deployment's secret"), std::string::npos)
        << guessed.err();

    // A CLI that holds the secret but is given a daemon's address for the name server's: the
    // daemon answers (it holds the secret too), but says it is a daemon, and the CLI stops there.
    auto misdirected = run_cli(dir, one, {"--names", one.address(), "list"});
    EXPECT_EQ(misdirected.status, 4) << misdirected.out;
    EXPECT_NE(misdirected.err.find(one.address() + " is a daemon, not a name server"), std::string::npos)
        << misdirected.err;

    // A daemon with no secret (run --insecure) cannot register with the name server...
    const std::string socket = dir.file("outsider.sock");
    Process intruder(outsider.wrap({plexusd_path(), "--listen", outsider.address() + ":0", "--insecure",
                                    "--names", names.address(), "--socket", socket, "--node", "intruder"}),
                     {}, dir.file("intruder"));
    ASSERT_TRUE(
        eventually([&] { return intruder.out().find("authentication required") != std::string::npos; }, 30s))
        << intruder.err() << "\n--- stdout:\n"
        << intruder.out();
    // ... so its ports and connections never exist for anyone else.
    auto evil = std::make_unique<Process>(
        outsider.wrap({plexus_path(), "--socket", socket, "read", "/evil/out", "--timeout", "5"}),
        std::map<std::string, std::string>{}, dir.file("evil"));
    Process connected(outsider.wrap({plexus_path(), "--socket", socket, "connect", "/evil/out", "/one/in"}),
                      {}, dir.file("connect"));
    EXPECT_EQ(connected.wait(30s), 4);
    EXPECT_FALSE(connected.err().empty());
    auto listed = run_cli(dir, one, {"list", "--json"});
    ASSERT_EQ(listed.status, 0) << listed.err;
    EXPECT_EQ(listed.out.find("intruder"), std::string::npos) << listed.out;
    EXPECT_EQ(listed.out.find("/evil/out"), std::string::npos) << listed.out;

    // A forged link straight to the daemon, claiming to be node "one": refused before its attach
    // is even read.
    const auto child =
        outsider.fork_inside([&] { return forge_attach(one.address(), "one", "/one/in", "/one/in"); });
    EXPECT_EQ(wait_child(child), 0);
    auto stats = run_cli(dir, one, {"stats", "/one/in", "--json"});
    ASSERT_EQ(stats.status, 0) << stats.err;
    const auto parsed = json::parse(stats.out);
    EXPECT_GE(parsed["daemon"]["auth_failures"].get<int>(), 1);
    EXPECT_TRUE(parsed["ports"][0]["inbound"].empty()) << stats.out;
}

TEST_F(Trust_test, DiscoveryAnswersWithoutTheDeploymentsProofAreIgnored) {
    // Two rogue name servers answer discovery (any plexus-names listening beyond loopback does):
    // one holds another secret, as a forger would hold none of ours, and proves that one; the
    // other has none and proves nothing. A daemon with the secret takes neither answer: it names
    // both as ignored and never connects to them, so neither learns anything of it.
    const std::string other = dir.file("rogue-secret");
    std::ofstream(other) << "a-secret-that-is-not-the-deployment-one";
    ::chmod(other.c_str(), 0600);
    const auto& keyed_host = net->host(0);
    const auto& open_host = net->host(2);
    const std::string keyed_ready = dir.file("keyed.ready");
    const std::string open_ready = dir.file("open.ready");
    Process keyed(keyed_host.wrap({names_path(), "--listen", keyed_host.address() + ":0", "--secret-file",
                                   other, "--ready-file", keyed_ready, "--log-level", "debug"}),
                  {}, dir.file("keyed"));
    Process open(open_host.wrap({names_path(), "--listen", open_host.address() + ":0", "--insecure",
                                 "--ready-file", open_ready, "--log-level", "debug"}),
                 {}, dir.file("open"));
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(keyed_ready); }, 20s)) << keyed.err();
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(open_ready); }, 20s)) << open.err();
    const auto& host = net->host(1);
    Process daemon(
        host.wrap({plexusd_path(), "--node", "misled", "--socket", dir.file("misled.sock"), "--listen",
                   host.address() + ":0", "--secret-file", test_secret_file(), "--log-level", "debug"}),
        {}, dir.file("misled"));
    const std::string ignored = "ignored answers without this deployment's proof from ";
    ASSERT_TRUE(eventually(
        [&] {
            const auto log = daemon.out() + daemon.err();
            return log.find(ignored) != std::string::npos || !daemon.running();
        },
        30s))
        << daemon.out() << daemon.err();
    const auto log = daemon.out() + daemon.err();
    const auto line = log.substr(log.find(ignored));
    const auto said = line.substr(0, line.find('\n'));
    EXPECT_NE(said.find(keyed_host.address()), std::string::npos) << said;
    EXPECT_NE(said.find(open_host.address()), std::string::npos) << said;
    // It fell back to the default address instead (nothing listens there: it keeps trying).
    EXPECT_NE(log.find("name server 127.0.0.1:10100"), std::string::npos) << log;
    EXPECT_EQ(log.find("registered node 'misled'"), std::string::npos) << log;
    // Both rogues answered queries, and neither was ever connected to.
    EXPECT_NE(keyed.out().find("discovery query from " + host.address()), std::string::npos) << keyed.out();
    EXPECT_NE(open.out().find("discovery query from " + host.address()), std::string::npos) << open.out();
    EXPECT_EQ(keyed.out().find("TLS handshake"), std::string::npos) << keyed.out();
    EXPECT_EQ(keyed.out().find("misled"), std::string::npos) << keyed.out();
    EXPECT_EQ(open.out().find("misled"), std::string::npos) << open.out();
    EXPECT_EQ(open.out().find("authentication required"), std::string::npos) << open.out();
}

TEST_F(Trust_test, DiscoveryFindsTheNameServerThatProvesTheSecretPastARogueOne) {
    // The same rogue beside this deployment's name server: however the answers race, the daemon
    // registers with the one that proves the secret.
    const std::string other = dir.file("rogue-secret");
    std::ofstream(other) << "a-secret-that-is-not-the-deployment-one";
    ::chmod(other.c_str(), 0600);
    const auto& rogue_host = net->host(0);
    const std::string rogue_ready = dir.file("rogue.ready");
    Process rogue(rogue_host.wrap({names_path(), "--listen", rogue_host.address() + ":0", "--secret-file",
                                   other, "--ready-file", rogue_ready}),
                  {}, dir.file("rogue"));
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(rogue_ready); }, 20s)) << rogue.err();
    NameServerProcess names(dir, net->host(2));
    // Ready means registered: with the name server it names.
    Daemon daemon(dir, net->host(1), "found", discover_names);
    EXPECT_EQ(daemon.names(), names.address());
    EXPECT_EQ(rogue.out().find("TLS handshake"), std::string::npos) << rogue.out();
}

}  // namespace trust_test
}  // namespace plexus::test
