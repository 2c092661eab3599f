// Hostile peers of the shared-memory rings that try to stall the daemon (PROTOCOL.md, "Rings",
// "Waking"): a client that never reads its ring, one that wakes the daemon for nothing as fast as
// it can, and one that turns the wake-up descriptors it shares with the daemon against it. The
// daemon's one thread must serve everyone else throughout. (rings_test.cpp has the peers that
// lie and scribble.)
#include <atomic>
#include <thread>

#include "ring_checks.hpp"

namespace plexus::test::hostile {
namespace rings_wake_test {

// ---------------------------------------------------------------------------------------------
// Peers that stall, and peers that wake the daemon for nothing

TEST(HostileRings_test, AClientThatNeverReadsItsRingStallsNeitherTheDaemonNorOtherReaders) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    Client writer(Client::Options{daemon.socket()});
    Client reader(Client::Options{daemon.socket()});
    auto source = writer.open("/stream/out");
    auto sink = reader.open("/stream/in");
    RingPeer stuck(daemon);
    ASSERT_TRUE(stuck.start());
    // `latest`: the writer is not held back by this reader (a strict one would hold it back by
    // design); what must not happen is the daemon or the writer's other reader waiting for it.
    ASSERT_TRUE(open_through_rings(stuck, 1, "/stuck/in", {{"policy", "latest"}}));
    ASSERT_EQ(writer.connect("/stream/out", "/stuck/in"), "local");
    ASSERT_EQ(writer.connect("/stream/out", "/stream/in"), "local");

    // Four rings' worth of 4 KiB messages, each read by the good reader before the next is written.
    const std::size_t messages = 4 * stuck.ring_bytes() / 4096;
    for (std::size_t i = 0; i < messages; ++i) {
        source.write(Value{{"i", i}, {"pad", std::string(4096, 'x')}});
        bool got = false;
        while (!got) {
            const auto message = sink.read(exchange_timeout);
            ASSERT_TRUE(message.has_value()) << "message " << i << " did not reach the good reader in time";
            got = message->data.value("i", messages + 1) == i;
        }
    }

    auto& control = stuck.to_client_control();
    EXPECT_TRUE(eventually([&] {
        return control.tail.load(std::memory_order_acquire) - control.head.load(std::memory_order_acquire) ==
               stuck.ring_bytes();
    })) << "the stuck client's ring never filled";
    expect_others_served(dir, daemon, good, 0, 4);
    EXPECT_EQ(stuck.socket_end(), End::open) << "a slow reader is not a broken one";
}

TEST(HostileRings_test, SpuriousWakeUpsForASecondStallNobody) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    RingPeer peer(daemon);
    ASSERT_TRUE(peer.start());
    ASSERT_TRUE(open_through_rings(peer, 1, "/noisy/port"));

    std::atomic<std::uint64_t> signals{0};
    std::atomic<bool> hammering{true};
    const int to_daemon_data = peer.descriptor(proto::to_daemon_data);
    const int to_client_space = peer.descriptor(proto::to_client_space);
    std::thread hammer([&] {
        // Both eventfds the daemon waits on, as fast as this thread can write them, for a second.
        const auto until = Clock::now() + 1s;
        while (Clock::now() < until) {
            RingPeer::signal(to_daemon_data);
            RingPeer::signal(to_client_space);
            signals += 2;
        }
        hammering = false;
    });
    int round_trips = 0;
    int late = 0;
    do {
        if (!good.round_trip())
            ++late;
        ++round_trips;
    } while (hammering.load());
    hammer.join();

    EXPECT_EQ(late, 0) << late << " of " << round_trips << " round trips of the good client took longer than "
                       << exchange_timeout.count() << " ms while the eventfds were hammered";
    EXPECT_GT(signals.load(), 1000u);
    // Spurious wake-ups are no error: the hammering session still works.
    ASSERT_TRUE(peer.send(request_frame(2, {{"op", "node"}})));
    const auto reply = peer.reply_to(2);
    EXPECT_TRUE(reply && reply->code == proto::ReplyCode::ok);
    expect_others_served(dir, daemon, good, 0, 2);
    EXPECT_EQ(counter(daemon_counters(dir, daemon), "protocol_errors"), 0u);
}

/// A thread of the hostile client that takes every wake-up of an eventfd made blocking, with blocking
/// reads, before the daemon can. Stopped (released by wake-ups until it is) and joined however the
/// test ends, so that a failed assertion does not leave it running.
class WakeUpThief {
public:
    explicit WakeUpThief(int eventfd)
        : eventfd_(eventfd), thread_([this] {
              std::uint64_t count = 0;
              while (!stop_ && ::read(eventfd_, &count, sizeof count) > 0) {
              }
              stopped_ = true;
          }) {}
    ~WakeUpThief() {
        stop();
        thread_.join();
    }
    WakeUpThief(const WakeUpThief&) = delete;
    WakeUpThief& operator=(const WakeUpThief&) = delete;
    /// Asks it to stop and wakes it, repeatedly (the daemon may take a wake-up first); true once it
    /// has stopped.
    bool stop() {
        stop_ = true;
        return eventually([&] {
            RingPeer::signal(eventfd_);
            return stopped_.load();
        });
    }

private:
    int eventfd_;
    std::atomic<bool> stop_{false};
    std::atomic<bool> stopped_{false};
    std::thread thread_;
};

TEST(HostileRings_test, WakeUpDescriptorsMadeBlockingAndFullCannotHangTheDaemon) {
    // The descriptors a client gets are open file descriptions it shares with the daemon: a client
    // that clears O_NONBLOCK on its copy, then fills an eventfd's counter (to 2^64 - 2, after which
    // a write of 1 blocks) or empties it under the daemon (after which a read blocks), hangs the
    // daemon's one thread if the daemon ever makes a plain write or read there (it did, before the
    // wake-ups the daemon signals became pipes of its own and it read eventfds with RWF_NOWAIT).
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    struct Attack {
        std::string what;
        proto::RingDescriptor descriptor;  ///< filled, made blocking
        std::function<void(RingPeer&)> then;
    };
    const std::vector<Attack> attacks = {
        {"the to-client data wake-up full while the client says it sleeps", proto::to_client_data,
         [](RingPeer& peer) {
             peer.to_client_control().reader_waiting.store(1);
             peer.send(request_frame(2, {{"op", "node"}}));  // the daemon writes a reply and wakes us
         }},
        {"the to-daemon space wake-up full while the client says it waits for room", proto::to_daemon_space,
         [](RingPeer& peer) {
             peer.to_daemon_control().writer_waiting.store(1);
             peer.send(request_frame(2, {{"op", "node"}}));  // the daemon reads and wakes us
         }},
        {"the to-daemon data wake-up full when the client closes its socket", proto::to_daemon_data,
         [](RingPeer& peer) { peer.close_socket(); }},
    };
    int sessions = 0;
    for (const auto& attack : attacks) {
        for (int round = 0; round < 3; ++round) {
            SCOPED_TRACE(attack.what + ", round " + std::to_string(round));
            RingPeer peer(daemon);
            ASSERT_TRUE(peer.start());
            ++sessions;
            ASSERT_TRUE(open_through_rings(peer, 1, "/blocking/" + std::to_string(sessions)));
            const int fd = peer.descriptor(attack.descriptor);
            std::uint64_t count = 0;
            [[maybe_unused]] auto drained = ::read(fd, &count, sizeof count);  // not blocking yet
            peer.make_blocking(attack.descriptor);
            const std::uint64_t almost_full = ~std::uint64_t{0} - 1;
            [[maybe_unused]] auto filled = ::write(fd, &almost_full, sizeof almost_full);

            attack.then(peer);

            EXPECT_TRUE(good.round_trip()) << "the daemon hung";
            EXPECT_TRUE(still_answers(daemon, Listener::daemon_unix)) << "the daemon hung";
        }
    }
    {
        SCOPED_TRACE("the to-daemon data wake-up emptied under the daemon by a blocking read");
        RingPeer peer(daemon);
        ASSERT_TRUE(peer.start());
        ++sessions;
        ASSERT_TRUE(open_through_rings(peer, 1, "/blocking/" + std::to_string(sessions)));
        const int fd = peer.descriptor(proto::to_daemon_data);
        peer.make_blocking(proto::to_daemon_data);
        WakeUpThief thief(fd);
        ASSERT_TRUE(eventually([&] { return peer.to_daemon_control().reader_waiting.load() != 0; }))
            << "the daemon never slept on its ring";
        // Each wake-up makes the daemon's wait end (when epoll still sees it) and races the thief
        // to the counter: the daemon must find it empty without blocking, however often.
        for (int i = 1; i <= 2000; ++i) {
            RingPeer::signal(fd);
            if (i % 200 == 0 && !good.round_trip()) {
                ADD_FAILURE() << "the daemon hung after " << i << " wake-ups raced for";
                break;
            }
        }
        EXPECT_TRUE(thief.stop()) << "the thief thread is stuck";
    }
    expect_others_served(dir, daemon, good, 0, sessions + 1);
}

TEST(HostileRings_test, WakeUpsTheClientClosedCannotKillTheDaemon) {
    // The daemon wakes the client by writing into pipes whose read ends the client was given: with
    // no reader left, a write would raise SIGPIPE and end the daemon, unless it keeps a reader
    // itself while the session lasts.
    TempDir dir;
    Daemon daemon(dir, "solo");
    GoodClient good(daemon);
    RingPeer peer(daemon);
    ASSERT_TRUE(peer.start());
    ASSERT_TRUE(open_through_rings(peer, 1, "/closed/port"));

    peer.close_descriptor(proto::to_client_data);
    peer.close_descriptor(proto::to_daemon_space);
    peer.to_client_control().reader_waiting.store(1);  // so that the daemon signals both
    peer.to_daemon_control().writer_waiting.store(1);
    ASSERT_TRUE(peer.send(request_frame(2, {{"op", "node"}})));  // read, then answered, by the daemon

    EXPECT_TRUE(eventually([&] {
        return peer.to_client_control().tail.load() > peer.to_client_control().head.load();
    })) << "the daemon never answered";
    EXPECT_TRUE(daemon.process().running()) << "the daemon died";
    expect_others_served(dir, daemon, good, 0, 2);
}

}  // namespace rings_wake_test
}  // namespace plexus::test::hostile
