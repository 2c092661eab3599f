// The udp carrier under network faults, between daemons on separate hosts (network namespaces, see
// netns.hpp): random loss, one lost fragment of a large message, a message over the carrier's
// limit, and a cut cable. Faults are made with nftables and iproute2 inside the hosts, so that
// what the daemons count can be checked against what the network did, exactly.
//
// Every test: the name server on host 0, the writing daemon on host 1, the reading one on host 2.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iostream>
#include <random>
#include <set>
#include <thread>
#include <tuple>
#include <utility>

#include "harness.hpp"
#include "netns.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace udp_faults_test {

using nlohmann::json;

/// The port number of a daemon's address ("10.77.0.3:41234" → 41234): its udp carrier's too.
int port_of(const Daemon& daemon) {
    return std::stoi(daemon.address().substr(daemon.address().rfind(':') + 1));
}

/// Loads an nftables table `inet plx` with one input chain holding `rules` into `host`.
void nft_install(const Host& host, const std::vector<std::string>& rules) {
    std::string script =
        "nft -f - <<'EOF'\ntable inet plx {\n  chain input {\n"
        "    type filter hook input priority 0; policy accept;\n";
    for (const auto& rule : rules)
        script += "    " + rule + "\n";
    script += "  }\n}\nEOF\n";
    host.run_checked(script);
}

void nft_remove(const Host& host) {
    host.run_checked("nft delete table inet plx");
}

/// The packets counted by the rule of table `inet plx` whose comment is `comment`.
std::uint64_t nft_packets(const Host& host, const std::string& comment) {
    const auto listed = json::parse(host.run_checked("nft -j list table inet plx"));
    for (const auto& item : listed["nftables"]) {
        if (!item.contains("rule") || item["rule"].value("comment", "") != comment)
            continue;
        for (const auto& expr : item["rule"]["expr"]) {
            if (expr.contains("counter"))
                return expr["counter"]["packets"].get<std::uint64_t>();
        }
    }
    throw std::runtime_error("no nft rule with the comment '" + comment + "'");
}

/// The envelopes a `plexus read --envelope` printed so far.
std::vector<json> envelopes(const Process& reader) {
    return json_lines(reader.out());
}

/// The largest seq a reader printed so far (0 for none).
std::int64_t last_seq(const Process& reader) {
    const auto lines = envelopes(reader);
    return lines.empty() ? 0 : lines.back()["seq"].get<std::int64_t>();
}

/// Checks that what a reader printed came from `source`, in increasing seq order, each payload
/// the number written with it (the writer wrote line N as its Nth message), and returns the seqs
/// in 1..`last` that it did not print.
std::set<std::int64_t> missing_seqs(const std::vector<json>& lines, const std::string& source,
                                    std::int64_t last) {
    std::set<std::int64_t> missing;
    std::int64_t previous = 0;
    for (const auto& line : lines) {
        EXPECT_EQ(line["from"], source) << line;
        const auto seq = line["seq"].get<std::int64_t>();
        EXPECT_GT(seq, previous) << "out of order after " << previous;
        EXPECT_EQ(line["data"], seq) << line;
        for (auto s = previous + 1; s < seq; ++s)
            missing.insert(s);
        previous = std::max(previous, seq);
    }
    for (auto s = previous + 1; s <= last; ++s)
        missing.insert(s);
    return missing;
}

std::vector<std::uint8_t> random_bytes(std::size_t size, std::uint32_t seed) {
    std::mt19937 random(seed);
    std::vector<std::uint8_t> bytes(size);
    for (auto& b : bytes)
        b = static_cast<std::uint8_t>(random());
    return bytes;
}

/// The three processes every test has: a name server on host 0, daemons "one" (writes) on host 1
/// and "two" (reads) on host 2.
struct ThreeHosts {
    explicit ThreeHosts(const std::vector<std::string>& extra = {})
        : net(3),
          names(dir, net.host(0)),
          one(dir, net.host(1), "one", names.address(), extra),
          two(dir, net.host(2), "two", names.address(), extra) {}
    Network net;
    TempDir dir;
    NameServerProcess names;
    Daemon one;
    Daemon two;
};

TEST(UdpFaults_test, RandomLossOfFivePercentIsCountedExactly) {
    PLEXUS_NEEDS_NETNS();
    ThreeHosts hosts;
    auto& [net, dir, names, one, two] = hosts;
    // A queue longer than the whole run: no message may be dropped for a full queue, so that
    // every seq missing at the reader is one the network lost.
    auto reader =
        start_cli(dir, two, {"read", "/b/in", "--envelope", "--queue", "8192", "--timeout", "60"}, "reader");
    CliWriter writer(dir, one, "/a/out", "writer");
    ASSERT_TRUE(wait_port(dir, one, "/a/out"));
    ASSERT_TRUE(wait_port(dir, one, "/b/in"));
    auto connected = run_cli(dir, one, {"connect", "/a/out", "/b/in", "udp"});
    ASSERT_EQ(connected.status, 0) << connected.err;

    // Every message is one datagram, so dropped packets and lost messages are the same count.
    nft_install(net.host(2), {"udp dport " + std::to_string(port_of(two)) +
                              " numgen random mod 100 < 5 counter drop comment \"random\""});
    const int count = 2000;
    writer.send(numbered_lines(1, count));
    ASSERT_TRUE(eventually(
        [&] {
            const auto out = outgoing_stats(dir, one, "/a/out", "/b/in");
            return !out.is_null() && out["udp"]["messages"] == count;
        },
        30s))
        << outgoing_stats(dir, one, "/a/out", "/b/in");
    // Every datagram has passed the rule once the receiving daemon took all those it did not
    // drop (only this stream sends to its port): then the counter is final.
    std::uint64_t dropped = 0;
    ASSERT_TRUE(eventually(
        [&] {
            const auto stats = json::parse(run_cli(dir, two, {"stats", "--json"}).out);
            dropped = nft_packets(net.host(2), "random");
            return stats["daemon"]["udp_datagrams_received"].get<std::uint64_t>() + dropped == count;
        },
        30s));
    nft_remove(net.host(2));
    // Losses at the very end of a stream show only when something comes after them.
    const int tail = 10;
    writer.send(numbered_lines(count + 1, tail));
    ASSERT_TRUE(eventually([&] { return last_seq(*reader) == count + tail; }, 30s)) << reader->err();

    const auto missing = missing_seqs(envelopes(*reader), "/a/out", count + tail);
    const auto inbound = inbound_stats(dir, two, "/b/in", "/a/out");
    ASSERT_FALSE(inbound.is_null());
    std::cout << "random loss: " << count + tail << " messages, nft dropped " << dropped << ", lost "
              << inbound["lost"] << ", missing at the reader " << missing.size() << '\n';
    EXPECT_GT(dropped, 0u);
    EXPECT_EQ(inbound["lost"], dropped);
    EXPECT_EQ(inbound["lost"], missing.size());
    for (auto seq : missing)
        EXPECT_LE(seq, count) << "a message sent without loss is missing";
    EXPECT_EQ(inbound["dropped_full"], 0);
    EXPECT_EQ(inbound["incomplete"], 0);
    EXPECT_EQ(inbound["late"], 0);
    EXPECT_EQ(inbound["received"], count + tail - static_cast<int>(missing.size()));
    const auto out = outgoing_stats(dir, one, "/a/out", "/b/in");
    EXPECT_EQ(out["udp"]["dropped_send"], 0) << out;
    // The human form shows the same counters.
    auto human = run_cli(dir, two, {"stats", "/b/in"});
    EXPECT_NE(human.out.find("lost " + std::to_string(missing.size()) +
                             " (of which incomplete 0), late 0, "
                             "dropped full 0"),
              std::string::npos)
        << human.out;
    human = run_cli(dir, one, {"stats", "/a/out"});
    EXPECT_NE(human.out.find("udp: " + std::to_string(count + tail) + " messages in " +
                             std::to_string(count + tail) + " datagrams"),
              std::string::npos)
        << human.out;
    EXPECT_EQ(writer.finish(), 0) << writer.process().err();
}

TEST(UdpFaults_test, AMebibyteMessageMissingOneFragmentIsCountedLostNeverTorn) {
    PLEXUS_NEEDS_NETNS();
    ThreeHosts hosts;
    auto& [net, dir, names, one, two] = hosts;
    // Clients of the daemons' Unix sockets, from this process: sockets in the file system are
    // not behind a network namespace.
    Client receiving({two.socket()});
    Port in = receiving.open("/b/in");
    Client sending({one.socket()});
    Port out = sending.open("/a/out");
    ASSERT_EQ(sending.connect("/a/out", "/b/in", "udp"), "udp");

    // Exactly one fragment of the message is dropped: among datagrams to the daemon's port that
    // are longer than 1,000 bytes (only full fragments are; the small messages of this test are
    // not), numgen inc numbers them 0, 1, 2... from the rule's creation, and only the one
    // numbered 300 matches below a modulus far larger than any count this test sends. The first
    // rule counts every large datagram, to compare with what the sender sent.
    const std::string port = std::to_string(port_of(two));
    nft_install(net.host(2), {"udp dport " + port + " udp length > 1000 counter comment \"large\"",
                              "udp dport " + port +
                                  " udp length > 1000 numgen inc mod 1000000 == 300 counter drop comment "
                                  "\"one\""});
    const auto blob = random_bytes(1 << 20, 1);
    out.write(Value::binary(blob));
    json sent;
    ASSERT_TRUE(eventually(
        [&] {
            sent = outgoing_stats(dir, one, "/a/out", "/b/in");
            return !sent.is_null() && sent["udp"]["messages"] == 1 &&
                   nft_packets(net.host(2), "large") == sent["udp"]["datagrams"].get<std::uint64_t>();
        },
        20s))
        << sent << " large: " << nft_packets(net.host(2), "large");
    const auto dropped = nft_packets(net.host(2), "one");
    EXPECT_EQ(dropped, 1u);
    const auto fragments = sent["udp"]["datagrams"].get<std::uint64_t>();
    // 1 MiB and ~22 bytes of record head and CBOR fit in 749 fragments of 1,400 bytes (1,048,600).
    EXPECT_EQ(fragments, 749u);
    nft_remove(net.host(2));

    out.write(Value("after"));
    auto first = in.read(20s);
    ASSERT_TRUE(first);
    EXPECT_EQ(first->envelope.seq, 2u);  // never the torn 1 MiB message
    EXPECT_EQ(first->data, "after");
    auto inbound = inbound_stats(dir, two, "/b/in", "/a/out");
    ASSERT_FALSE(inbound.is_null());
    EXPECT_EQ(inbound["lost"], 1);
    EXPECT_EQ(inbound["incomplete"], 1);
    EXPECT_EQ(inbound["late"], 0);
    std::cout << "one fragment: " << fragments << " fragments sent, nft dropped " << dropped << ", lost "
              << inbound["lost"] << ", incomplete " << inbound["incomplete"] << '\n';

    // Without loss, several in a burst arrive whole, byte for byte.
    const int many = 4;
    for (int i = 0; i < many; ++i)
        out.write(Value::binary(random_bytes(1 << 20, 10 + i)));
    for (int i = 0; i < many; ++i) {
        auto message = in.read(20s);
        ASSERT_TRUE(message) << "message " << i << " of " << many << ": "
                             << inbound_stats(dir, two, "/b/in", "/a/out");
        EXPECT_EQ(message->envelope.seq, 3u + i);
        ASSERT_TRUE(message->data.is_binary());
        EXPECT_TRUE(static_cast<const std::vector<std::uint8_t>&>(message->data.get_binary()) ==
                    random_bytes(1 << 20, 10 + i))
            << "message " << i;
    }
    inbound = inbound_stats(dir, two, "/b/in", "/a/out");
    EXPECT_EQ(inbound["lost"], 1) << inbound;
    EXPECT_EQ(inbound["received"], 1 + many);
    const auto stats = json::parse(run_cli(dir, two, {"stats", "--json"}).out);
    EXPECT_EQ(stats["daemon"]["udp_reassembly_bytes"], 0);  // nothing left half-built
}

TEST(UdpFaults_test, AMessageOverTheLimitIsDroppedAtTheSenderSaidAndCounted) {
    PLEXUS_NEEDS_NETNS();
    TempDir configs;
    const std::string config = configs.file("udp.json");
    std::ofstream(config) << R"({"udp_max_message": 100000})";
    ThreeHosts hosts({"--config", config});
    auto& [net, dir, names, one, two] = hosts;
    Client receiving({two.socket()});
    Port in = receiving.open("/b/in");
    Client sending({one.socket()});
    Port out = sending.open("/a/out");
    ASSERT_EQ(sending.connect("/a/out", "/b/in", "udp"), "udp");

    const auto under = random_bytes(99000, 1);  // a record of 99,000 bytes and its head
    out.write(Value::binary(under));
    out.write(Value::binary(random_bytes(150000, 2)));
    out.write(Value("after"));
    auto first = in.read(20s);
    ASSERT_TRUE(first);
    EXPECT_EQ(first->envelope.seq, 1u);
    ASSERT_TRUE(first->data.is_binary());
    EXPECT_TRUE(static_cast<const std::vector<std::uint8_t>&>(first->data.get_binary()) == under);
    auto second = in.read(20s);
    ASSERT_TRUE(second);
    EXPECT_EQ(second->envelope.seq, 3u);
    EXPECT_EQ(second->data, "after");

    const auto sent = outgoing_stats(dir, one, "/a/out", "/b/in");
    ASSERT_FALSE(sent.is_null());
    EXPECT_EQ(sent["udp"]["dropped_too_large"], 1) << sent;
    EXPECT_EQ(sent["udp"]["messages"], 2) << sent;
    const auto log = one.process().out() + one.process().err();
    EXPECT_NE(log.find("connection /a/out -> /b/in: a message of "), std::string::npos) << log;
    EXPECT_NE(log.find("is larger than the udp carrier's limit 100000 (udp_max_message): dropped"),
              std::string::npos)
        << log;
    // It never took a stream number: the receiver has nothing to count lost.
    const auto inbound = inbound_stats(dir, two, "/b/in", "/a/out");
    EXPECT_EQ(inbound["lost"], 0) << inbound;
    EXPECT_EQ(inbound["received"], 2) << inbound;
    auto human = run_cli(dir, one, {"stats", "/a/out"});
    EXPECT_NE(human.out.find("dropped too large 1"), std::string::npos) << human.out;

    // Values the carrier could not work with are refused when the daemon starts, saying why.
    const std::vector<std::pair<std::string, std::string>> refused{
        {R"({"udp_fragment_bytes": 100})", "udp_fragment_bytes must be between 256 and 65000, not 100"},
        {R"({"udp_fragment_bytes": 70000})", "udp_fragment_bytes must be between 256 and 65000"},
        {R"({"udp_max_message": 0})", "udp_max_message must be between 1 and max_frame (67108864), not 0"},
        {R"({"max_frame": 1048576, "udp_max_message": 2000000})",
         "udp_max_message must be between 1 and max_frame (1048576)"},
        {R"({"udp_fragment_bytes": 256, "udp_max_message": 67108864, "udp_reassembly_bytes": 67108864})",
         "more than a datagram may say (65536)"},
        {R"({"udp_max_message": 1000000, "udp_reassembly_bytes": 999999})",
         "udp_reassembly_bytes (999999) must be at least udp_max_message (1000000)"},
        {R"({"udp_timeout_ms": 0})", "udp_timeout_ms must be between 10 and 600000, not 0"},
    };
    for (std::size_t i = 0; i < refused.size(); ++i) {
        const std::string bad = configs.file("bad" + std::to_string(i) + ".json");
        std::ofstream(bad) << refused[i].first;
        Process daemon({plexusd_path(), "--config", bad, "--socket", configs.file("bad.sock")}, {},
                       configs.file("bad" + std::to_string(i)));
        EXPECT_EQ(daemon.wait(20s), 2) << refused[i].first;
        EXPECT_NE(daemon.err().find(refused[i].second), std::string::npos)
            << refused[i].first << ": " << daemon.err();
    }
    // A smaller frame limit alone takes the udp limit down with it, rather than being refused.
    const std::string small = configs.file("small.json");
    std::ofstream(small) << R"({"max_frame": 1048576})";
    TempDir small_dir;
    Daemon small_daemon(small_dir, net.host(1), "small", names.address(), {"--config", small});
}

TEST(UdpFaults_test, ACutCableHealsWithoutReconnectingAndUdpCountsWhatItLost) {
    PLEXUS_NEEDS_NETNS();
    ThreeHosts hosts;
    auto& [net, dir, names, one, two] = hosts;
    auto udp_reader = start_cli(
        dir, two, {"read", "/b/in", "--envelope", "--queue", "8192", "--timeout", "90"}, "udp-reader");
    auto tcp_reader = start_cli(dir, two, {"read", "/d/in", "--envelope", "--timeout", "90"}, "tcp-reader");
    CliWriter udp_writer(dir, one, "/a/out", "udp-writer");
    CliWriter tcp_writer(dir, one, "/c/out", "tcp-writer");
    for (const auto* port : {"/a/out", "/b/in", "/c/out", "/d/in"})
        ASSERT_TRUE(wait_port(dir, one, port)) << port;
    for (const auto& [source, destination, carrier] :
         {std::tuple{"/a/out", "/b/in", "udp"}, std::tuple{"/c/out", "/d/in", "tcp"}}) {
        auto connected = run_cli(dir, one, {"connect", source, destination, carrier});
        ASSERT_EQ(connected.status, 0) << connected.err;
    }
    // Both writers write the same numbers; line N is the Nth message of each, so its seq is N.
    int next = 1;
    const auto write_both = [&](int n) {
        udp_writer.send(numbered_lines(next, n));
        tcp_writer.send(numbered_lines(next, n));
        next += n;
    };

    write_both(100);
    ASSERT_TRUE(
        eventually([&] { return last_seq(*udp_reader) == 100 && last_seq(*tcp_reader) == 100; }, 20s));
    const long rss_one_before = one.rss_kib();
    const long rss_two_before = two.rss_kib();

    // The cut: host 2's cable, pulled out of the switch (its end of the veth in the switch goes
    // down). The host keeps its address and routes, as a machine whose cable is unplugged does.
    const std::string cable = "ip link set " + net.host(2).bridge_port();
    net.bridge().run_checked(cable + " down");
    const int first_cut = next;
    const auto cut_at = std::chrono::steady_clock::now();
    // The fault lasts 5 s, with writing going on all along: this sleep is the fault's duration
    // and the writers' pace, not a wait for an outcome. Of every 10 udp messages one is a 1 MiB
    // string, ~50 MiB in all: a sender that kept what it could not deliver would show it.
    const std::string large_line = "\"" + std::string(1 << 20, 'x') + "\"\n";
    while (std::chrono::steady_clock::now() - cut_at < 5s) {
        udp_writer.send(numbered_lines(next, 9) + large_line);
        tcp_writer.send(numbered_lines(next, 10));
        next += 10;
        std::this_thread::sleep_for(100ms);
    }
    const int last_cut = next - 1;
    // The cable comes back only once daemon one has sent every message of the cut into it: a
    // writer's last lines could still be on their way through a slow daemon (a sanitized build),
    // and would then cross the healed cable instead of being lost.
    EXPECT_TRUE(eventually([&] {
        const auto out = outgoing_stats(dir, one, "/a/out", "/b/in");
        return !out.is_null() && out["udp"]["messages"] == last_cut;
    })) << outgoing_stats(dir, one, "/a/out", "/b/in");
    const long rss_one_cut = one.rss_kib();
    const long rss_two_cut = two.rss_kib();
    net.bridge().run_checked(cable + " up");

    // After the heal, writing goes on with nobody reconnecting anything: tcp retransmits what it
    // held, udp had nothing to lose but the datagrams of the cut.
    write_both(100);
    const int last = next - 1;
    EXPECT_TRUE(eventually([&] { return last_seq(*udp_reader) == last; }, 30s)) << last_seq(*udp_reader);
    EXPECT_TRUE(eventually([&] { return last_seq(*tcp_reader) == last; }, 30s)) << last_seq(*tcp_reader);

    // tcp: everything, in order.
    EXPECT_TRUE(missing_seqs(envelopes(*tcp_reader), "/c/out", last).empty());
    // udp: every message of the cut lost, and counted so; nothing else.
    const auto missing = missing_seqs(envelopes(*udp_reader), "/a/out", last);
    const auto inbound = inbound_stats(dir, two, "/b/in", "/a/out");
    ASSERT_FALSE(inbound.is_null());
    std::cout << "cut: " << last_cut - first_cut + 1 << " udp messages written during the cut, lost "
              << inbound["lost"] << ", missing at the reader " << missing.size() << "; rss one "
              << rss_one_before << " -> " << rss_one_cut << " -> " << one.rss_kib() << " KiB, two "
              << rss_two_before << " -> " << rss_two_cut << " -> " << two.rss_kib() << " KiB\n";
    EXPECT_EQ(inbound["lost"], missing.size());
    std::set<std::int64_t> cut;
    for (int seq = first_cut; seq <= last_cut; ++seq)
        cut.insert(seq);
    EXPECT_EQ(missing, cut);
    EXPECT_EQ(inbound["incomplete"], 0);
    EXPECT_EQ(inbound["dropped_full"], 0);

    // The same connections, never re-made: both still there, and the sender never saw one go.
    for (const auto& [source, destination] : {std::pair{"/a/out", "/b/in"}, std::pair{"/c/out", "/d/in"}})
        EXPECT_FALSE(outgoing_stats(dir, one, source, destination).is_null()) << source;
    const auto sender_log = one.process().out() + one.process().err();
    EXPECT_EQ(sender_log.find("went down"), std::string::npos) << sender_log;
    const auto receiver_log = two.process().out() + two.process().err();
    for (const auto* link : {"link /a/out -> /b/in closed", "link /c/out -> /d/in closed"})
        EXPECT_EQ(receiver_log.find(link), std::string::npos) << receiver_log;
    // Memory stays bounded: udp held nothing back, tcp a few hundred small messages. The bound is
    // stretched by slowdown() (harness.hpp): ASan's redzones and quarantine grow RSS without a leak.
    const long max_growth_kib = static_cast<long>(32 * 1024 * slowdown());
    for (const auto& [before, during, after] : {std::tuple{rss_one_before, rss_one_cut, one.rss_kib()},
                                                std::tuple{rss_two_before, rss_two_cut, two.rss_kib()}}) {
        EXPECT_LT(during, before + max_growth_kib);
        EXPECT_LT(after, before + max_growth_kib);
    }
    EXPECT_EQ(udp_writer.finish(), 0);
    EXPECT_EQ(tcp_writer.finish(), 0);
    // The links end when their writers do, and say so where the check above looked.
    EXPECT_TRUE(eventually([&] {
        const auto log = two.process().out() + two.process().err();
        return log.find("link /a/out -> /b/in closed") != std::string::npos &&
               log.find("link /c/out -> /d/in closed") != std::string::npos;
    }));
}

}  // namespace udp_faults_test
}  // namespace plexus::test
