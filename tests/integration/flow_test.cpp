// Flow control and faults: slow readers under each queue policy, and clients that die.
#include <gtest/gtest.h>

#include <signal.h>

#include <atomic>
#include <cstdlib>
#include <fstream>
#include <future>
#include <mutex>
#include <sstream>
#include <thread>

#include "harness.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace flow_test {

nlohmann::json port_stats(Client& client, const std::string& port) {
    auto stats = client.stats(port);
    for (const auto& p : stats["ports"]) {
        if (p["name"] == port)
            return p;
    }
    return nullptr;
}

TEST(Flow_test, AReadWithAZeroTimeoutPollsTheSocket) {
    // A component stepping its own loop polls its inputs with read(0ms): that must take what the
    // daemon has sent, not only what some other, blocking call happened to receive.
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client reading({daemon.socket()});
    auto sink = reading.open("/polled");
    Client writing({daemon.socket()});
    auto source = writing.open("/polling/source");
    writing.connect("/polling/source", "/polled");
    source.write(42);
    std::optional<Received> got;
    ASSERT_TRUE(eventually([&] { return (got = sink.read(std::chrono::milliseconds(0))).has_value(); }));
    EXPECT_EQ(got->data, 42);
    EXPECT_FALSE(sink.read(std::chrono::milliseconds(0)).has_value());  // and returns at once when empty
}

TEST(Flow_test, LatestPolicyNeverBlocksTheWriterAndCountsEveryDrop) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client reading({daemon.socket()});
    auto sink = reading.open("/slow", {QueuePolicy::latest, 8});
    Client writing({daemon.socket()});
    auto source = writing.open("/fast");
    writing.connect("/fast", "/slow");
    const std::string kilobyte(1024, 'x');
    constexpr int total = 50000;  // 50 MB: far more than any socket buffer holds

    for (int i = 0; i < total; ++i)
        source.write(kilobyte, false);  // returns: the writer is never held
    source.flush();

    // Everything written was either delivered to the reader's socket, dropped, or is still queued.
    ASSERT_TRUE(eventually([&] { return port_stats(writing, "/slow")["received"] == total; }));
    auto stats = port_stats(writing, "/slow");
    EXPECT_GT(stats["dropped_queue"].get<int>(), 0);
    EXPECT_LE(stats["depth"].get<int>(), 8);
    EXPECT_EQ(stats["delivered"].get<int>() + stats["dropped_queue"].get<int>() + stats["depth"].get<int>(),
              total);
    // The reader then gets what was kept, newest last, with gaps where drops happened.
    std::uint64_t last_seq = 0;
    int read = 0;
    while (auto message = sink.read(std::chrono::milliseconds(500))) {
        EXPECT_GT(message->envelope.seq, last_seq);
        last_seq = message->envelope.seq;
        ++read;
    }
    EXPECT_EQ(last_seq, static_cast<std::uint64_t>(total));
    EXPECT_LT(read, total);
}

TEST(Flow_test, StrictPolicyLosesNothingAndHoldsTheWriterBack) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client reading({daemon.socket()});
    auto sink = reading.open("/careful", {QueuePolicy::strict, 8});
    Client writing({daemon.socket()});
    auto source = writing.open("/eager");
    writing.connect("/eager", "/careful");
    const std::string kilobyte(1024, 'y');
    constexpr int total = 50000;
    // A writer held back by a strict reader cannot send requests either: watch from a third client.
    Client observing({daemon.socket()});
    std::atomic<bool> done{false};
    std::thread writer([&] {
        for (int i = 0; i < total; ++i)
            source.write(kilobyte, false);
        source.flush();
        done = true;
    });

    // The reader does not read: the queue fills to its bound and stays there.
    ASSERT_TRUE(eventually([&] { return port_stats(observing, "/careful")["depth"] == 8; }));
    auto held = port_stats(observing, "/careful");
    EXPECT_EQ(held["dropped_queue"], 0);
    EXPECT_FALSE(done.load()) << "50 MB cannot fit in socket buffers: the writer must be held back";

    for (int i = 1; i <= total; ++i) {
        auto message = sink.read(std::chrono::seconds(30));
        ASSERT_TRUE(message.has_value()) << "message " << i << " missing";
        ASSERT_EQ(message->envelope.seq, static_cast<std::uint64_t>(i));
    }
    writer.join();
    EXPECT_TRUE(done.load());
    EXPECT_EQ(port_stats(observing, "/careful")["dropped_queue"], 0);
}

TEST(Flow_test, AClientThatWritesIntoItsOwnFullStrictPortDoesNotDeadlock) {
    // One thread writes into a strict port that the same client reads only afterwards. The daemon
    // stops reading the client once that port is full; the blocked write must read what arrives
    // meanwhile, or the client waits for itself forever.
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client client({daemon.socket()});
    auto in = client.open("/self/in", {QueuePolicy::strict, 4});
    auto out = client.open("/self/out");
    client.connect("/self/out", "/self/in");
    constexpr int total = 3000;  // 12 MB: far more than the queue and both sockets hold
    const std::string block(4096, 's');
    std::promise<void> finished;
    auto result = finished.get_future();
    std::thread scenario([&] {
        for (int i = 0; i < total; ++i)
            out.write(block);
        for (int i = 1; i <= total; ++i) {
            auto message = in.read(std::chrono::seconds(30));
            if (!message || message->envelope.seq != static_cast<std::uint64_t>(i)) {
                ADD_FAILURE() << "message " << i << (message ? " out of order" : " missing");
                break;
            }
        }
        finished.set_value();
    });
    if (result.wait_for(std::chrono::seconds(120)) != std::future_status::ready) {
        ADD_FAILURE() << "the client deadlocked writing into its own full strict port";
        std::_Exit(1);  // the scenario thread cannot be stopped; end the test program
    }
    scenario.join();
}

TEST(Flow_test, AClientThatDiesMidWriteLosesItsPortsAndNobodyElseIsHurt) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client reading({daemon.socket()});
    auto sink = reading.open("/sink", {QueuePolicy::strict, 4});
    std::ostringstream lines;
    for (int i = 0; i < 200000; ++i)
        lines << "\"" << std::string(512, 'z') << i << "\"\n";
    {
        std::ofstream input(dir.file("many.in"));
        input << lines.str();
    }
    std::vector<std::string> argv{plexus_path(), "write", "/doomed", "/sink"};
    Process writer(argv, daemon.env(), dir.file("writer"), dir.file("many.in"));
    // The reader does not read, so the writer is stuck mid-stream when it is killed.
    ASSERT_TRUE(eventually([&] { return port_stats(reading, "/sink")["depth"] == 4; }));
    ASSERT_TRUE(writer.running());

    writer.signal(SIGKILL);
    ASSERT_EQ(writer.wait(10s), 128 + SIGKILL);

    EXPECT_TRUE(eventually([&] { return run_cli(dir, daemon, {"exists", "/doomed"}).status == 1; }));
    // What the dead writer had sent is intact and still delivered.
    auto first = sink.read(std::chrono::seconds(10));
    ASSERT_TRUE(first.has_value());
    EXPECT_EQ(first->envelope.source, "/doomed");
    EXPECT_EQ(first->data, std::string(512, 'z') + "0");
    while (sink.read(std::chrono::milliseconds(200))) {
    }
    // Other ports are unaffected: a new writer reaches the same reader.
    ASSERT_EQ(run_cli(dir, daemon, {"write", "/survivor", "/sink"}, "\"still here\"\n").status, 0);
    auto after = sink.read(std::chrono::seconds(10));
    ASSERT_TRUE(after.has_value());
    EXPECT_EQ(after->data, "still here");
    EXPECT_EQ(after->envelope.source, "/survivor");
}

TEST(Flow_test, ADaemonThatGoesAwayTakesItsPortsOffTheNameServer) {
    TempDir dir;
    Daemon names_host(dir, "host");
    auto other = std::make_unique<Daemon>(dir, "leaving", names_host.names());
    auto holder = start_cli(dir, *other, {"read", "/leaving/port", "--timeout", "30"}, "holder");
    ASSERT_TRUE(wait_port(dir, names_host, "/leaving/port"));

    other->process().signal(SIGKILL);  // no orderly unregistering: the name server must notice
    ASSERT_TRUE(other->process().wait(10s).has_value());

    EXPECT_TRUE(eventually(
        [&] {
            return run_cli(dir, names_host, {"exists", "/leaving/port"}).status == 1;
        },
        20s));
}

TEST(Flow_test, DaemonsRegisterAgainWhenTheNameServerRestarts) {
    TempDir dir;
    Daemon host(dir, "host");  // embedded name server on a free port
    Daemon worker(dir, "worker", host.names());
    auto holder = start_cli(dir, worker, {"read", "/worker/in", "--timeout", "60"}, "holder");
    ASSERT_TRUE(wait_port(dir, host, "/worker/in"));
    const std::string where = host.names();

    host.process().signal(SIGTERM);  // the name server goes away with its daemon
    ASSERT_TRUE(host.process().wait(10s).has_value());
    Process standalone({names_path(), "--listen", where}, {}, dir.file("names"));

    EXPECT_TRUE(eventually(
        [&] {
            return run_cli(dir, worker, {"exists", "/worker/in"}).status == 0;
        },
        20s))
        << "the worker daemon should have registered /worker/in again";
}

TEST(Flow_test, AnOrderlyShutdownUnregistersAtOnceRatherThanAfterTheGracePeriod) {
    TempDir dir;
    {
        std::ofstream config(dir.file("long-grace.json"));
        config << R"({"names_grace_ms": 600000})";
    }
    Daemon names_host(dir, "host", "", {"--config", dir.file("long-grace.json")});
    Daemon leaving(dir, "leaving", names_host.names());
    auto holder = start_cli(dir, leaving, {"read", "/leaving/port", "--timeout", "60"}, "holder");
    ASSERT_TRUE(wait_port(dir, names_host, "/leaving/port"));

    leaving.process().signal(SIGTERM);

    ASSERT_EQ(leaving.process().wait(10s), 0);
    EXPECT_EQ(run_cli(dir, names_host, {"exists", "/leaving/port"}).status, 1)
        << "with a 10-minute grace period only an explicit unregister removes the port this fast";
}

TEST(Flow_test, ASubscriptionCallsBackForEveryMessage) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client reading({daemon.socket()});
    auto sink = reading.open("/callback/sink");
    std::mutex mutex;
    std::vector<std::uint64_t> seen;
    Subscription subscription(sink, [&](const Received& message) {
        std::lock_guard lock(mutex);
        seen.push_back(message.data.get<std::uint64_t>());
    });

    ASSERT_EQ(run_cli(dir, daemon, {"write", "/callback/source", "/callback/sink"}, "1\n2\n3\n").status, 0);

    EXPECT_TRUE(eventually([&] {
        std::lock_guard lock(mutex);
        return seen.size() == 3;
    }));
    std::lock_guard lock(mutex);
    EXPECT_EQ(seen, (std::vector<std::uint64_t>{1, 2, 3}));
}

}  // namespace flow_test
}  // namespace plexus::test
