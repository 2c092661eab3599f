// The web endpoint across hosts (network namespaces, netns.hpp): the page one daemon serves shows
// the other daemon's ports and counters, gathered over the daemons' authenticated link; beyond
// loopback it answers only a request carrying the web token.
#include <gtest/gtest.h>

#include "harness.hpp"
#include "netns.hpp"
#include "web_paths.hpp"

namespace plexus::test {
namespace web_hosts_test {

using nlohmann::json;

/// How an https URL's certificate is checked: against a CA certificate file, or by its SHA-256.
struct Trusting {
    std::string ca_file;
    std::string fingerprint;
};

/// GET `url` from inside `host`: the status code and the body.
std::pair<int, std::string> get_from(const Host& host, const std::string& url, const std::string& header = "",
                                     const Trusting& trusting = {}) {
    std::string command =
        (trusting.ca_file.empty() ? "" : "PLEXUS_CA_FILE='" + trusting.ca_file + "' ") +
        (trusting.fingerprint.empty() ? "" : "PLEXUS_CERT_SHA256='" + trusting.fingerprint + "' ") +
        python_path() + " " + web_tests_dir() + "/http_get.py '" + url + "'";
    if (!header.empty())
        command += " '" + header + "'";
    const auto result = host.run(command, std::chrono::seconds(60));
    if (result.status != 0)
        return {0, result.err};
    const auto newline = result.out.find('\n');
    return {std::stoi(result.out.substr(0, newline)), result.out.substr(newline + 1)};
}

TEST(WebHosts_test, ThePageOfOneDaemonShowsTheOtherDaemonsPortsAndCountersOnlyWithTheToken) {
    PLEXUS_NEEDS_NETNS();
    Network net(3);
    TempDir dir;
    NameServerProcess names(dir, net.host(0));
    Daemon watched(dir, net.host(1), "watched", names.address(), {"--http", net.host(1).address() + ":0"});
    Daemon other(dir, net.host(2), "other", names.address());

    // Traffic on the other daemon only: its counters must come over the link. The reader stays,
    // so its port does (a daemon shows on the page while it hosts a port the name server lists).
    const int count = 30;
    auto reader = start_cli(dir, other, {"read", "/other/in"}, "reader");
    ASSERT_TRUE(wait_port(dir, other, "/other/in"));
    CliWriter writer(dir, other, "/other/out", "writer");
    ASSERT_TRUE(wait_port(dir, other, "/other/out"));
    ASSERT_EQ(run_cli(dir, other, {"connect", "/other/out", "/other/in"}).status, 0);
    writer.send(numbered_lines(0, count));
    ASSERT_TRUE(eventually([&] { return port_stats(dir, other, "/other/in").value("received", 0) == count; },
                           slower(30s)));
    auto sensor = start_cli(dir, watched, {"read", "/watched/in", "--timeout", "60"}, "sensor");
    ASSERT_TRUE(wait_port(dir, watched, "/watched/in"));

    const auto printed = run_cli(dir, watched, {"web"});
    ASSERT_EQ(printed.status, 0) << printed.err;
    // Beyond loopback with the secret alone: HTTPS, with a certificate the daemon made at its
    // start, whose fingerprint `plexus web` prints (a person compares it with the browser's).
    const std::string url = printed.out.substr(0, printed.out.find('\n'));
    ASSERT_EQ(url.rfind("https://" + net.host(1).address() + ":", 0), 0u) << url;
    const auto sha = printed.out.find("SHA-256 ");
    ASSERT_NE(sha, std::string::npos) << printed.out;
    const Trusting pinned{"", printed.out.substr(sha + 8, 95)};  // 32 bytes, AB:CD:...
    const auto token = run_cli(dir, watched, {"web", "--token"});
    ASSERT_EQ(token.status, 0) << token.err;
    const std::string bearer = "Authorization: Bearer " + token.out.substr(0, token.out.find('\n'));

    // From the other host, beyond loopback: refused without the token, answered with it.
    const auto refused = get_from(net.host(2), url + "api/system", "", pinned);
    EXPECT_EQ(refused.first, 401) << refused.second;
    const auto wrong = get_from(net.host(2), url + "api/system", "Authorization: Bearer 0123", pinned);
    EXPECT_EQ(wrong.first, 401) << wrong.second;
    const auto answered = get_from(net.host(2), url + "api/system", bearer, pinned);
    ASSERT_EQ(answered.first, 200) << answered.second;
    const auto system = json::parse(answered.second);
    json other_part;
    for (const auto& node : system["nodes"]) {
        if (node["node"] == "other")
            other_part = node;
    }
    ASSERT_FALSE(other_part.is_null()) << system.dump(2);
    EXPECT_TRUE(other_part["error"].is_null()) << other_part["error"];
    json in_port;
    for (const auto& port : other_part["stats"]["ports"]) {
        if (port["name"] == "/other/in")
            in_port = port;
    }
    ASSERT_FALSE(in_port.is_null()) << other_part.dump(2);
    EXPECT_EQ(in_port["received"], count);
    ASSERT_EQ(other_part["arbitration"].size(), 1u) << other_part["arbitration"];
    EXPECT_EQ(other_part["arbitration"][0]["port"], "/other/in");

    // The cookie works as the header does, once /login has set it.
    const auto login =
        get_from(net.host(2), url + "login?token=" + token.out.substr(0, token.out.find('\n')), "", pinned);
    EXPECT_EQ(login.first, 303) << login.second;  // to the page, with the cookie set
    const auto with_cookie =
        get_from(net.host(2), url + "api/node",
                 "Cookie: plexus_token=" + token.out.substr(0, token.out.find('\n')), pinned);
    EXPECT_EQ(with_cookie.first, 200) << with_cookie.second;

    // Another certificate (a host in the middle showing its own) is refused; plain HTTP gets no page.
    const auto other_certificate =
        get_from(net.host(2), url + "api/system", bearer, Trusting{"", std::string(95, 'A')});
    EXPECT_EQ(other_certificate.first, 0) << other_certificate.second;
    std::string plain = url;
    plain.replace(0, 5, "http");
    EXPECT_NE(get_from(net.host(2), plain + "api/system", bearer).first, 200);

    // Every refusal counted, as `plexus stats` shows.
    const auto stats = json::parse(run_cli(dir, watched, {"stats", "--json"}).out);
    EXPECT_GE(stats["http"]["refused"]["token"].get<int>(), 2) << stats["http"];
}

TEST(WebHosts_test, WithAnIdentityThePageIsServedOverHttpsWithTheNodesCertificate) {
    PLEXUS_NEEDS_NETNS();
    Network net(3);
    TempDir dir;
    // The CA, the name server's identity, and the watched node's with its address for browsers.
    const std::string ca = dir.file("ca");
    const auto pki = [&](std::vector<std::string> args) {
        args.insert(args.begin(), {plexus_path(), "pki"});
        Process process(args, {}, dir.file("pki-" + args.at(3)));
        return process.wait(30s).value_or(-1);
    };
    ASSERT_EQ(pki({"init", ca}), 0);
    ASSERT_EQ(pki({"issue", "names0", "--names", "--ca", ca}), 0);
    ASSERT_EQ(pki({"issue", "watched", "--ca", ca, "--web", net.host(1).address()}), 0);
    NameServerProcess names(dir, net.host(0), {"--identity", ca + "/names/names0"});
    Daemon watched(dir, net.host(1), "watched", names.address(),
                   {"--identity", ca + "/nodes/watched", "--http", net.host(1).address() + ":0"});

    const auto printed = run_cli(dir, watched, {"web"});
    ASSERT_EQ(printed.status, 0) << printed.err;
    const std::string url = printed.out.substr(0, printed.out.find('\n'));
    ASSERT_EQ(url.rfind("https://" + net.host(1).address() + ":", 0), 0u) << url;
    const auto token = run_cli(dir, watched, {"web", "--token"});
    const std::string bearer = "Authorization: Bearer " + token.out.substr(0, token.out.find('\n'));

    // A browser that trusts the deployment's CA: the certificate names the address, the token opens it.
    const auto answered = get_from(net.host(2), url + "api/node", bearer, Trusting{ca + "/ca.crt"});
    ASSERT_EQ(answered.first, 200) << answered.second;
    EXPECT_EQ(json::parse(answered.second)["node"], "watched");
    EXPECT_EQ(get_from(net.host(2), url + "api/node", "", Trusting{ca + "/ca.crt"}).first, 401);
    // One that does not trust it refuses the certificate; plain HTTP gets no page.
    const auto untrusted = get_from(net.host(2), url + "api/node", bearer);
    EXPECT_EQ(untrusted.first, 0);
    EXPECT_NE(untrusted.second.find("CERTIFICATE_VERIFY_FAILED"), std::string::npos) << untrusted.second;
    std::string plain = url;
    plain.replace(0, 5, "http");
    EXPECT_NE(get_from(net.host(2), plain + "api/node", bearer).first, 200);
}

}  // namespace web_hosts_test
}  // namespace plexus::test
