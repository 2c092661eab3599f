// Large payloads through shared memory between clients and their local daemon (PROTOCOL.md,
// "Shared memory"): what arrives, which path it took (the daemon's shm_passed / shm_copied
// counters), and that regions and slots are given back.
#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>
#include <fstream>
#include <thread>

#include "harness.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace shm_test {

constexpr std::size_t mib = 1024 * 1024;

/// A blob whose every byte depends on `seed`: a payload mixed up with another, or read from a slot
/// the writer had already reused, does not compare equal.
Value blob(std::size_t size, std::uint32_t seed) {
    std::vector<std::uint8_t> bytes(size);
    std::uint32_t x = seed * 2654435761u + 1;
    for (auto& b : bytes) {
        x = x * 1664525u + 1013904223u;
        b = static_cast<std::uint8_t>(x >> 24);
    }
    return Value::binary(std::move(bytes));
}

std::uint64_t daemon_counter(Client& client, const std::string& key) {
    return client.stats()["daemon"][key].get<std::uint64_t>();
}

/// Reads `count` messages and checks each is blob(size, first_seed + i), in order.
void expect_blobs(Port& port, std::size_t count, std::size_t size, std::uint32_t first_seed = 0) {
    for (std::size_t i = 0; i < count; ++i) {
        auto message = port.read(20s);
        ASSERT_TRUE(message.has_value()) << "message " << i << " of " << count << " never arrived";
        ASSERT_TRUE(message->data == blob(size, first_seed + static_cast<std::uint32_t>(i)))
            << "message " << i << " arrived changed";
    }
}

std::string config_file(const TempDir& dir, const nlohmann::json& config) {
    const auto path = dir.file("plexusd.json");
    std::ofstream(path) << config.dump();
    return path;
}

/// A writer and a reader, each a client of its own, with NAME/source connected to NAME/sink.
struct Pair {
    Pair(const Daemon& daemon, const std::string& name)
        : writer(Client::Options{daemon.socket()}),
          reader(Client::Options{daemon.socket()}),
          source(writer.open(name + "/source")),
          sink(reader.open(name + "/sink")) {
        writer.connect(source.name(), sink.name());
    }
    Client writer;
    Client reader;
    Port source;
    Port sink;
};

TEST(Shm_test, ALargeBlobTravelsThroughSharedMemoryAndArrivesIntact) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Pair pair(daemon, "/shm");
    auto& [writer, reader, source, sink] = pair;

    // Five at a time, fewer than the region holds; the writer learns its slots are free again
    // before its stats reply (the daemon's frees come first on its connection).
    for (std::uint32_t round = 0; round < 4; ++round) {
        for (std::uint32_t i = 0; i < 5; ++i)
            source.write(blob(mib, round * 5 + i));
        expect_blobs(sink, 5, mib, round * 5);
        ASSERT_TRUE(eventually([&] { return daemon_counter(writer, "shm_slots") == 0; }));
    }

    EXPECT_EQ(daemon_counter(writer, "shm_passed"), 20u);
    EXPECT_EQ(daemon_counter(writer, "shm_copied"), 0u);
    EXPECT_EQ(daemon_counter(writer, "shm_regions"), 1u);
    const auto shown = run_cli(dir, daemon, {"stats"});
    ASSERT_EQ(shown.status, 0) << shown.err;
    EXPECT_NE(
        shown.out.find("shared memory: 1 regions (8 MiB), 0 payloads held, 20 passed in place, 0 copied out"),
        std::string::npos)
        << shown.out;
}

TEST(Shm_test, EveryReaderOfAFanOutGetsTheSamePayload) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client writer({daemon.socket()});
    auto source = writer.open("/fan/source");
    std::vector<std::unique_ptr<Client>> readers;
    std::vector<Port> sinks;
    for (int i = 0; i < 3; ++i) {
        readers.push_back(std::make_unique<Client>(Client::Options{daemon.socket()}));
        sinks.push_back(readers.back()->open("/fan/sink" + std::to_string(i)));
        writer.connect("/fan/source", sinks.back().name());
    }

    for (std::uint32_t i = 0; i < 10; ++i)
        source.write(blob(300 * 1024, i));
    for (auto& sink : sinks)
        expect_blobs(sink, 10, 300 * 1024);

    EXPECT_EQ(daemon_counter(writer, "shm_passed"), 10u) << "each message is passed once, for all readers";
}

TEST(Shm_test, APayloadThatIsNotAByteStringIsRebuiltAsItsRecord) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Pair pair(daemon, "/map");
    auto& [writer, reader, source, sink] = pair;
    const Value map = {{"scan", std::string(200000, 'r')}, {"points", std::vector<int>(20000, 7)}};

    source.write(map);
    auto message = sink.read(20s);

    ASSERT_TRUE(message.has_value());
    EXPECT_EQ(message->data, map);
    EXPECT_EQ(message->envelope.source, "/map/source");
    EXPECT_EQ(daemon_counter(writer, "shm_passed"), 1u);
}

TEST(Shm_test, WhenOneConnectionIsRemoteTheDaemonCopiesThePayloadOutForAll) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client writer({daemon.socket()});
    Client reader({daemon.socket()});
    auto source = writer.open("/mixed/source");
    auto plain = reader.open("/mixed/plain");
    auto over_tcp = reader.open("/mixed/tcp");
    writer.connect("/mixed/source", "/mixed/plain");
    ASSERT_EQ(writer.connect("/mixed/source", "/mixed/tcp", "tcp"), "tcp");

    for (std::uint32_t i = 0; i < 5; ++i)
        source.write(blob(mib, i));
    expect_blobs(plain, 5, mib);
    expect_blobs(over_tcp, 5, mib);

    EXPECT_EQ(daemon_counter(writer, "shm_passed"), 0u);
    EXPECT_EQ(daemon_counter(writer, "shm_copied"), 5u);
}

TEST(Shm_test, AFullRegionHoldsTheWriterOrSendsThroughTheSocketAndNothingIsLostOrReordered) {
    TempDir dir;
    // The smallest region for 400 KiB payloads: four times one, rounded up to 2 MiB, holds five.
    Daemon daemon(dir, "solo", "", {"--config", config_file(dir, {{"shm_region_bytes", mib}})});
    Pair pair(daemon, "/full");
    auto& [writer, reader, source, sink] = pair;
    constexpr std::size_t size = 400 * 1024;

    // Nobody reads the first eight: the region fills after five, the sixth waits in vain and
    // takes the socket, and so do the next until a slot comes free.
    for (std::uint32_t i = 0; i < 8; ++i)
        source.write(blob(size, i));
    std::thread reading([&] { expect_blobs(sink, 60, size); });
    for (std::uint32_t i = 8; i < 60; ++i)
        source.write(blob(size, i));
    reading.join();

    const auto passed = daemon_counter(writer, "shm_passed");
    EXPECT_GE(passed, 5u);
    EXPECT_LT(passed, 60u) << "the region cannot have held the eight unread messages at once";
    EXPECT_EQ(daemon_counter(writer, "shm_bytes"), 2 * mib);
}

TEST(Shm_test, AReaderThatLeavesWithoutReadingGivesItsSlotsBack) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", {"--config", config_file(dir, {{"shm_region_bytes", 4 * mib}})});
    Client writer({daemon.socket()});
    Client stays({daemon.socket()});
    auto source = writer.open("/leave/source");
    auto kept = stays.open("/leave/kept");
    writer.connect("/leave/source", "/leave/kept");
    {
        Client leaves({daemon.socket()});
        auto dropped = leaves.open("/leave/dropped");
        writer.connect("/leave/source", "/leave/dropped");
        for (std::uint32_t i = 0; i < 3; ++i)
            source.write(blob(mib, i));
        expect_blobs(kept, 3, mib);
    }  // leaves without reading or releasing: three of the region's four slots are held for it
    // (five MiB: four 1 MiB payloads, rounded up)

    ASSERT_TRUE(eventually([&] { return daemon_counter(writer, "shm_slots") == 0; }))
        << "the slots of the reader that left are still held";
    // Nobody reads now: the three fit only if the slots held for the reader that left came back.
    for (std::uint32_t i = 3; i < 6; ++i)
        source.write(blob(mib, i));
    EXPECT_EQ(daemon_counter(writer, "shm_passed"), 6u);
    expect_blobs(kept, 3, mib, 3);
}

TEST(Shm_test, APayloadLargerThanThePortsRegionTakesTheSocket) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", {"--config", config_file(dir, {{"shm_region_bytes", mib}})});
    Pair pair(daemon, "/grow");
    auto& [writer, reader, source, sink] = pair;

    source.write(blob(100 * 1024, 0));  // the region is made for this size: 1 MiB
    source.write(blob(3 * mib, 1));     // does not fit in it at all

    auto first = sink.read(20s);
    auto second = sink.read(20s);
    ASSERT_TRUE(first && second);
    EXPECT_TRUE(first->data == blob(100 * 1024, 0));
    EXPECT_TRUE(second->data == blob(3 * mib, 1));
    EXPECT_EQ(daemon_counter(writer, "shm_passed"), 1u);
    EXPECT_EQ(daemon_counter(writer, "shm_bytes"), mib);
}

TEST(Shm_test, OneClientWritingAndReadingItsOwnLargeMessagesOnTwoThreadsNeverStalls) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client both({daemon.socket()});
    auto source = both.open("/self/source");
    auto sink = both.open("/self/sink", {QueuePolicy::strict, 4});
    both.connect("/self/source", "/self/sink");
    constexpr std::uint32_t count = 200;

    // The writer waits for slots while the other thread is the connection's reader, and the
    // reader releases slots while the writer may be sending: neither may wait for the other.
    std::thread reading([&] { expect_blobs(sink, count, 300 * 1024); });
    for (std::uint32_t i = 0; i < count; ++i)
        source.write(blob(300 * 1024, i));
    reading.join();

    EXPECT_GT(daemon_counter(both, "shm_passed"), 0u);
}

TEST(Shm_test, OneThreadWritingIntoItsOwnFullPortBeforeReadingNeverStalls) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client both({daemon.socket()});
    auto source = both.open("/alone/source");
    auto sink = both.open("/alone/sink", {QueuePolicy::strict, 4});
    both.connect("/alone/source", "/alone/sink");

    // More than the region holds and far more than the queue: the writer must read its own
    // messages (and so release their slots) while it waits, or it would wait for itself.
    for (std::uint32_t i = 0; i < 60; ++i)
        source.write(blob(300 * 1024, i));
    expect_blobs(sink, 60, 300 * 1024);
}

TEST(Shm_test, ARegionGoesOnceItsPortIsClosedAndItsMessagesAreRead) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client writer({daemon.socket()});
    Client reader({daemon.socket()});
    auto sink = reader.open("/gone/sink");
    {
        auto source = writer.open("/gone/source");
        writer.connect("/gone/source", "/gone/sink");
        source.write(blob(mib, 1));
        source.write(blob(mib, 2));
        EXPECT_EQ(daemon_counter(writer, "shm_regions"), 1u);
    }
    expect_blobs(sink, 2, mib, 1);
    EXPECT_TRUE(eventually([&] { return daemon_counter(reader, "shm_regions") == 0; }))
        << "the region outlived its port and its messages";
    EXPECT_EQ(daemon_counter(reader, "shm_bytes"), 0u);
}

TEST(Shm_test, TheDaemonStopsCleanlyWithRegionsAndSlotsInUse) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    Pair pair(daemon, "/stop");
    auto& [writer, reader, source, sink] = pair;
    for (std::uint32_t i = 0; i < 4; ++i)
        source.write(blob(mib, i));
    ASSERT_TRUE(eventually([&] { return daemon_counter(writer, "shm_slots") == 4; }));  // none read

    daemon.process().signal(SIGTERM);

    EXPECT_EQ(daemon.process().wait(10s), 0) << daemon.process().err();
}

TEST(Shm_test, PlexusShmZeroKeepsEveryPayloadInTheSocket) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    ::setenv("PLEXUS_SHM", "0", 1);
    Client writer({daemon.socket()});
    Client reader({daemon.socket()});
    ::unsetenv("PLEXUS_SHM");
    auto source = writer.open("/off/source");
    auto sink = reader.open("/off/sink");
    writer.connect("/off/source", "/off/sink");

    for (std::uint32_t i = 0; i < 3; ++i)
        source.write(blob(mib, i));
    expect_blobs(sink, 3, mib);

    EXPECT_EQ(daemon_counter(writer, "shm_passed"), 0u);
    EXPECT_EQ(daemon_counter(writer, "shm_regions"), 0u);
}

TEST(Shm_test, ADaemonWithSharedMemoryOffStillCarriesLargeBlobs) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", {"--config", config_file(dir, {{"shm_region_bytes", 0}})});
    Pair pair(daemon, "/noshm");
    auto& [writer, reader, source, sink] = pair;

    for (std::uint32_t i = 0; i < 3; ++i)
        source.write(blob(mib, i));
    expect_blobs(sink, 3, mib);
    EXPECT_EQ(daemon_counter(writer, "shm_passed"), 0u);
}

}  // namespace shm_test
}  // namespace plexus::test
