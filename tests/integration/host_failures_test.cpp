// Failures of whole machines' software and of their cables, on separate hosts (network namespaces,
// see netns.hpp): a daemon killed with -9 mid-stream and started again (the writer's, then the
// reader's), and a cable cut for 60 s, longer than any keep-alive, then healed. In each, the
// stream comes back with nobody re-making anything, and what was lost is where the test says.
//
// Every test: the name server on host 0, the writing daemon "one" on host 1, the reading daemon
// "two" on host 2. The components are Clients of this test program, reaching their daemons' Unix
// sockets (which network namespaces do not separate), as a component on that host would.
#include <signal.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <functional>
#include <iostream>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "harness.hpp"
#include "netns.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace host_failures_test {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

/// The hosts, their daemons, and a component on each daemon: `writing` on one, `reading` on two
/// (destroyed before the daemons).
struct ThreeHosts {
    ThreeHosts()
        : net(3),
          names(dir, net.host(0)),
          one(dir, net.host(1), "one", names.address()),
          two(dir, net.host(2), "two", names.address()),
          writing({one.socket()}),
          reading({two.socket()}) {}
    Network net;
    TempDir dir;
    NameServerProcess names;
    Daemon one;
    Daemon two;
    Client writing;
    Client reading;
};

/// Sequence numbers in 1..last that `seqs` (increasing) does not hold.
std::vector<std::uint64_t> missing_up_to(const std::vector<std::uint64_t>& seqs, std::uint64_t last) {
    std::vector<std::uint64_t> missing;
    std::size_t at = 0;
    for (std::uint64_t seq = 1; seq <= last; ++seq) {
        if (at < seqs.size() && seqs[at] == seq)
            ++at;
        else
            missing.push_back(seq);
    }
    return missing;
}

/// Checks that `missing` is one run of consecutive numbers, and says it.
void expect_one_run(const std::vector<std::uint64_t>& missing) {
    if (missing.empty())
        return;
    EXPECT_EQ(missing.back() - missing.front() + 1, missing.size())
        << "the loss is not one run: " << missing.size() << " between " << missing.front() << " and "
        << missing.back();
}

/// Reads `sink` into `seqs` until it holds `last`, or `timeout` passes; checks each payload is its
/// seq. `first_after`, when given, gets the time the first seq above `after` arrived.
bool read_until(Port& sink, std::vector<std::uint64_t>& seqs, std::uint64_t last,
                std::chrono::milliseconds timeout, std::optional<Clock::time_point>* first_after = nullptr,
                std::uint64_t after = 0) {
    const auto deadline = Clock::now() + timeout;
    while ((seqs.empty() || seqs.back() < last) && Clock::now() < deadline) {
        auto message = sink.read(200ms);
        if (!message)
            continue;
        EXPECT_EQ(message->data.get<std::uint64_t>(), message->envelope.seq);
        seqs.push_back(message->envelope.seq);
        if (first_after && !*first_after && message->envelope.seq > after)
            *first_after = Clock::now();
    }
    return !seqs.empty() && seqs.back() >= last;
}

long long ms_since(Clock::time_point start, Clock::time_point end) {
    return std::chrono::duration_cast<std::chrono::milliseconds>(end - start).count();
}

/// Writes 1, 2, 3... with `write` every `pace` on a thread of its own, until destroyed (also when
/// a test fails): the pace of a sensor, not a wait for anything.
class PacedWriter {
public:
    PacedWriter(std::function<void(std::uint64_t)> write, std::chrono::milliseconds pace)
        : thread_([this, write = std::move(write), pace] {
              while (!stop_) {
                  write(written_ + 1);
                  ++written_;
                  std::this_thread::sleep_for(pace);
              }
          }) {}
    ~PacedWriter() { stop(); }
    void stop() {
        stop_ = true;
        if (thread_.joinable())
            thread_.join();
    }
    std::uint64_t written() const { return written_; }

private:
    std::atomic<std::uint64_t> written_{0};
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

TEST(HostFailures_test, KillingTheWritersDaemonLosesOnlyWhatItHeldAndTheStreamResumes) {
    PLEXUS_NEEDS_NETNS();
    ThreeHosts hosts;
    auto& [net, dir, names, one, two, writing, reading] = hosts;
    auto source = writing.open("/k/out");
    auto sink = reading.open("/k/in");
    writing.connect("/k/out", "/k/in", "tcp");
    std::vector<std::uint64_t> seqs;

    for (std::uint64_t i = 1; i <= 200; ++i)
        source.write(i);
    ASSERT_TRUE(read_until(sink, seqs, 200, 20s));
    // 201..300 written, then the writer's daemon killed: what it held is all that may go.
    for (std::uint64_t i = 201; i <= 300; ++i)
        source.write(i);
    one.process().signal(SIGKILL);
    ASSERT_TRUE(one.process().wait(10s).has_value());
    ASSERT_TRUE(eventually([&] { return writing.state() == ConnectionState::disconnected; }));
    // Written while the daemon is away: held by libplexus, sent once it is back.
    for (std::uint64_t i = 301; i <= 350; ++i)
        source.write(i);

    const auto restarted = Clock::now();
    one.start_again();
    std::optional<Clock::time_point> first_after;
    ASSERT_TRUE(read_until(sink, seqs, 350, 60s, &first_after, 300))
        << "received up to " << (seqs.empty() ? 0 : seqs.back()) << "; " << one.process().err();
    for (std::uint64_t i = 351; i <= 400; ++i)
        source.write(i);
    ASSERT_TRUE(read_until(sink, seqs, 400, 20s));

    EXPECT_TRUE(std::is_sorted(seqs.begin(), seqs.end()));
    EXPECT_EQ(std::set<std::uint64_t>(seqs.begin(), seqs.end()).size(), seqs.size());
    const auto missing = missing_up_to(seqs, 400);
    expect_one_run(missing);
    if (!missing.empty()) {
        EXPECT_GT(missing.front(), 200u);
        EXPECT_LE(missing.back(), 300u);
    }
    EXPECT_EQ(source.dropped_while_disconnected(), 0u);
    EXPECT_EQ(writing.state(), ConnectionState::reconnected);
    std::printf(
        "[ writer's daemon killed ] lost %zu message(s), all inside it (seq %llu..%llu); first message "
        "across hosts %lld ms after it was started again\n",
        missing.size(), missing.empty() ? 0ULL : static_cast<unsigned long long>(missing.front()),
        missing.empty() ? 0ULL : static_cast<unsigned long long>(missing.back()),
        ms_since(restarted, *first_after));
}

TEST(HostFailures_test, KillingTheReadersDaemonResumesAPersistentStreamAndCountsWhatWentNowhere) {
    PLEXUS_NEEDS_NETNS();
    ThreeHosts hosts;
    auto& [net, dir, names, one, two, writing, reading] = hosts;
    auto source = writing.open("/k/out");
    auto sink = reading.open("/k/in");
    writing.connect("/k/out", "/k/in", "tcp", true);
    std::vector<std::uint64_t> seqs;

    // The writer writes all along, one message per millisecond.
    PacedWriter writer([&](std::uint64_t seq) { source.write(seq); }, 1ms);

    ASSERT_TRUE(read_until(sink, seqs, 300, 20s));
    two.process().signal(SIGKILL);
    const std::uint64_t read_before_kill = seqs.back();
    ASSERT_TRUE(two.process().wait(10s).has_value());
    // The reader's Port keeps what reached the reader before its daemon went.
    while (auto message = sink.read(50ms))
        seqs.push_back(message->envelope.seq);
    const std::uint64_t had_before_kill = seqs.back();
    ASSERT_TRUE(eventually([&] { return reading.state() == ConnectionState::disconnected; }));

    const auto restarted = Clock::now();
    const std::uint64_t written_at_restart = writer.written();
    two.start_again();
    std::optional<Clock::time_point> first_after;
    ASSERT_TRUE(read_until(sink, seqs, written_at_restart + 500, 60s, &first_after, had_before_kill))
        << "received up to " << seqs.back() << "; " << two.process().err();
    writer.stop();
    const std::uint64_t last = written_at_restart + 500;

    EXPECT_TRUE(std::is_sorted(seqs.begin(), seqs.end()));
    EXPECT_EQ(std::set<std::uint64_t>(seqs.begin(), seqs.end()).size(), seqs.size());
    const auto missing = missing_up_to(seqs, last);
    expect_one_run(missing);
    ASSERT_FALSE(missing.empty());  // the writer wrote on while the reader's daemon was away
    EXPECT_GT(missing.front(), read_before_kill);
    // What went nowhere while the connection was down is counted at the writer's daemon: messages
    // written with no connection out of the port, and any the broken link still held. The rest of
    // the loss was inside the killed daemon or in the kernels' socket buffers between the hosts.
    const json port = port_stats(dir, one, "/k/out");
    ASSERT_FALSE(port.is_null());
    const auto unconnected = port.value("unconnected", std::uint64_t{0});
    const auto counters = json::parse(run_cli(dir, one, {"stats", "--json"}).out)["daemon"];
    const auto link_down = counters.value("dropped_link_down", std::uint64_t{0});
    EXPECT_GT(unconnected, 0u);
    EXPECT_LE(unconnected + link_down, missing.size());
    std::printf(
        "[ reader's daemon killed ] missing %zu message(s), one run (seq %llu..%llu): %llu written while "
        "the connection was down, %llu lost from the broken link's queue, %llu inside the killed daemon "
        "or the socket buffers; first message %lld ms after it was started again\n",
        missing.size(), static_cast<unsigned long long>(missing.front()),
        static_cast<unsigned long long>(missing.back()), static_cast<unsigned long long>(unconnected),
        static_cast<unsigned long long>(link_down),
        static_cast<unsigned long long>(missing.size() - unconnected - link_down),
        ms_since(restarted, *first_after));
}

TEST(HostFailures_test, ACableCutForAMinuteHealsAndPersistentConnectionsComeBackByThemselves) {
    PLEXUS_NEEDS_NETNS();
    ThreeHosts hosts;
    auto& [net, dir, names, one, two, writing, reading] = hosts;
    auto tcp_source = writing.open("/t/out");
    auto udp_source = writing.open("/u/out");
    auto tcp_sink = reading.open("/t/in", {.capacity = 8192});
    auto udp_sink = reading.open("/u/in", {.capacity = 8192});
    writing.connect("/t/out", "/t/in", "tcp", true);
    writing.connect("/u/out", "/u/in", "udp", true);
    std::vector<std::uint64_t> tcp_seqs;
    std::vector<std::uint64_t> udp_seqs;

    // Both writers write the same numbers all along, one message each per 10 ms.
    PacedWriter writer(
        [&](std::uint64_t seq) {
            tcp_source.write(seq);
            udp_source.write(seq);
        },
        10ms);
    ASSERT_TRUE(read_until(tcp_sink, tcp_seqs, 100, 20s));
    ASSERT_TRUE(read_until(udp_sink, udp_seqs, 100, 20s));
    const long rss_one_before = one.rss_kib();
    const long rss_two_before = two.rss_kib();

    // Host 2's cable out of the switch for 60 s: longer than the keep-alives (about 6 s) and the
    // timeout of unacknowledged data on links, so every TCP connection to host 2 ends, and the
    // name server forgets host 2's ports.
    const std::string cable = "ip link set " + net.host(2).bridge_port();
    net.bridge().run_checked(cable + " down");
    const auto cut_at = Clock::now();
    const std::uint64_t written_at_cut = writer.written();
    long rss_one_most = 0;
    long rss_two_most = 0;
    // The fault's duration: polled every second, for memory, while the writer goes on.
    while (Clock::now() - cut_at < 60s) {
        std::this_thread::sleep_for(1s);
        rss_one_most = std::max(rss_one_most, one.rss_kib());
        rss_two_most = std::max(rss_two_most, two.rss_kib());
    }
    // What reached host 2's daemon before the cut is read meanwhile.
    const std::uint64_t written_at_heal = writer.written();
    net.bridge().run_checked(cable + " up");
    const auto healed_at = Clock::now();

    std::optional<Clock::time_point> tcp_back;
    std::optional<Clock::time_point> udp_back;
    ASSERT_TRUE(read_until(tcp_sink, tcp_seqs, written_at_heal + 200, 90s, &tcp_back, written_at_heal))
        << "tcp received up to " << tcp_seqs.back() << "\none: " << one.process().err()
        << "\ntwo: " << two.process().err();
    ASSERT_TRUE(read_until(udp_sink, udp_seqs, written_at_heal + 200, 30s, &udp_back, written_at_heal))
        << "udp received up to " << udp_seqs.back();
    writer.stop();

    for (const auto* seqs : {&tcp_seqs, &udp_seqs}) {
        EXPECT_TRUE(std::is_sorted(seqs->begin(), seqs->end()));
        EXPECT_EQ(std::set<std::uint64_t>(seqs->begin(), seqs->end()).size(), seqs->size());
    }
    // Everything written: what went nowhere may reach past written_at_heal + 200 when the
    // connections took long to come back, so the losses are counted over all of it. tcp delivers
    // all the rest; udp may lose some more on the way, which the read only waits a while for.
    const std::uint64_t last = writer.written();
    ASSERT_TRUE(read_until(tcp_sink, tcp_seqs, last, 30s)) << "tcp received up to " << tcp_seqs.back();
    read_until(udp_sink, udp_seqs, last, 5s);
    const auto tcp_missing = missing_up_to(tcp_seqs, last);
    const auto udp_missing = missing_up_to(udp_seqs, last);
    // Nothing lost before the cut; the losses are the cut's and the time the connections took to
    // come back, counted at the writer's daemon where they happened there.
    for (const auto& missing : {tcp_missing, udp_missing}) {
        ASSERT_FALSE(missing.empty());
        EXPECT_GT(missing.front(), written_at_cut - 100);
    }
    const auto tcp_port = port_stats(dir, one, "/t/out");
    const auto udp_port = port_stats(dir, one, "/u/out");
    const auto counters = json::parse(run_cli(dir, one, {"stats", "--json"}).out)["daemon"];
    std::printf(
        "[ 60 s cut ] tcp back %lld ms after the heal, missing %zu (seq %llu..%llu, %zu runs), "
        "unconnected %llu, dropped_link_down %llu; udp back %lld ms after, missing %zu, unconnected %llu; "
        "rss one %ld -> %ld (most while cut) -> %ld KiB, two %ld -> %ld -> %ld KiB\n",
        ms_since(healed_at, *tcp_back), tcp_missing.size(),
        static_cast<unsigned long long>(tcp_missing.front()),
        static_cast<unsigned long long>(tcp_missing.back()),
        static_cast<std::size_t>(std::count_if(tcp_missing.begin(), tcp_missing.end(),
                                               [&](std::uint64_t s) {
                                                   return std::find(tcp_missing.begin(), tcp_missing.end(),
                                                                    s - 1) == tcp_missing.end();
                                               })),
        static_cast<unsigned long long>(tcp_port.value("unconnected", std::uint64_t{0})),
        static_cast<unsigned long long>(counters.value("dropped_link_down", std::uint64_t{0})),
        ms_since(healed_at, *udp_back), udp_missing.size(),
        static_cast<unsigned long long>(udp_port.value("unconnected", std::uint64_t{0})), rss_one_before,
        rss_one_most, one.rss_kib(), rss_two_before, rss_two_most, two.rss_kib());
    // tcp: what went nowhere at the writer's daemon is counted there; the rest of the loss was in
    // the kernels' socket buffers when the links ended. udp has no acknowledgement: what it sent
    // into the cut before its connection ended is lost uncounted (the new connection's counters
    // start afresh).
    EXPECT_LE(tcp_port.value("unconnected", std::uint64_t{0}) +
                  counters.value("dropped_link_down", std::uint64_t{0}),
              tcp_missing.size());
    EXPECT_GT(tcp_port.value("unconnected", std::uint64_t{0}), 0u);
    EXPECT_GT(udp_port.value("unconnected", std::uint64_t{0}), 0u);
    // Memory stays bounded while cut: 6,000 small messages per stream at most were written.
    EXPECT_LT(rss_one_most, rss_one_before + 32 * 1024);
    EXPECT_LT(rss_two_most, rss_two_before + 32 * 1024);
    // Back within a bound: the daemons retry every 2 s at most.
    EXPECT_LT(ms_since(healed_at, *tcp_back), 30000);
    EXPECT_LT(ms_since(healed_at, *udp_back), 30000);
}

}  // namespace host_failures_test
}  // namespace plexus::test
