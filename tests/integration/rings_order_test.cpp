// Order under the shared-memory transport: several threads of one client write on ports of their
// own, through one session's rings, with every way of writing mixed (buffered small messages that
// become batch frames, flushing writes, large blobs through shared memory, zero-copy loans), while
// the threads of another client read with read and read_view, some reading for themselves and
// some through the receiving thread. Each port's messages must arrive whole, in order, none lost
// and none twice; and the same with the rings turned off (PLEXUS_RINGS=0) for comparison.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <thread>

#include "harness.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace rings_order_test {

constexpr int streams = 4;
constexpr std::uint32_t per_stream = 6000;

/// Message i of stream s: its kind by i, its bytes by (s, i).
std::size_t size_of(std::uint32_t i) {
    switch (i % 50) {
        case 7:
            return 300 * 1024;  // a large blob: through shared memory
        case 23:
            return 100 * 1024;  // a loan
        default:
            return 16 + i % 200;  // small: batched or flushed
    }
}

void write_stream(Port& port, int stream) {
    for (std::uint32_t i = 0; i < per_stream; ++i) {
        const std::size_t size = size_of(i);
        if (i % 50 == 23) {
            Loan loan = port.loan(size);
            fill_stream_bytes(loan.bytes(), stream, i);
            port.send_loan(std::move(loan), i % 3 == 0);
            continue;
        }
        std::vector<std::uint8_t> bytes(size);
        fill_stream_bytes(bytes, stream, i);
        port.write(Value::binary(std::move(bytes)), i % 10 == 0 || size > 1000);
    }
    port.flush();
}

/// Reads the whole stream, checking each message; the first problem, or "".
std::string read_stream(Port& port, int stream, bool views) {
    std::uint64_t expected_seq = 0;
    for (std::uint32_t i = 0; i < per_stream; ++i) {
        std::vector<std::uint8_t> expected(size_of(i));
        fill_stream_bytes(expected, stream, i);
        std::span<const std::uint8_t> got;
        std::optional<MessageView> view;
        std::optional<Received> message;
        std::uint64_t seq = 0;
        if (views) {
            view = port.read_view(std::chrono::seconds(30));
            if (!view)
                return "stream " + std::to_string(stream) + ": message " + std::to_string(i) + " never came";
            got = view->bytes();
            seq = view->envelope().seq;
        } else {
            message = port.read(std::chrono::seconds(30));
            if (!message)
                return "stream " + std::to_string(stream) + ": message " + std::to_string(i) + " never came";
            if (!message->data.is_binary())
                return "stream " + std::to_string(stream) + ": message " + std::to_string(i) + " not a blob";
            got = {message->data.get_binary().data(), message->data.get_binary().size()};
            seq = message->envelope.seq;
        }
        if (expected_seq != 0 && seq != expected_seq + 1)
            return "stream " + std::to_string(stream) + ": seq " + std::to_string(seq) + " after " +
                   std::to_string(expected_seq);
        expected_seq = seq;
        if (got.size() != expected.size() || std::memcmp(got.data(), expected.data(), got.size()) != 0)
            return "stream " + std::to_string(stream) + ": message " + std::to_string(i) + " arrived changed";
    }
    if (auto extra = port.read(std::chrono::milliseconds(0)))
        return "stream " + std::to_string(stream) + ": a message more than was written";
    return "";
}

void run_streams(const Daemon& daemon) {
    Client writer({daemon.socket()});
    Client reader({daemon.socket()});
    std::vector<Port> sources;
    std::vector<Port> sinks;
    for (int s = 0; s < streams; ++s) {
        sources.push_back(writer.open("/order/source" + std::to_string(s)));
        sinks.push_back(reader.open("/order/sink" + std::to_string(s)));
        writer.connect(sources.back().name(), sinks.back().name());
    }
    std::vector<std::string> problems(streams);
    {
        std::vector<std::jthread> threads;
        for (int s = 0; s < streams; ++s) {
            threads.emplace_back([&, s] { problems[s] = read_stream(sinks[s], s, s % 2 == 1); });
            threads.emplace_back([&, s] { write_stream(sources[s], s); });
        }
    }
    for (const auto& problem : problems)
        EXPECT_EQ(problem, "");
}

TEST(RingsOrder_test, EveryPortKeepsItsOrderAcrossThreadsRingsSharedMemoryAndLoans) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    run_streams(daemon);
    Client observer({daemon.socket()});
    const auto counters = observer.stats()["daemon"];
    EXPECT_GE(counters["ring_sessions"].get<std::uint64_t>(), 2u);
    EXPECT_GT(counters["shm_passed"].get<std::uint64_t>(), 0u);
    EXPECT_EQ(counters["protocol_errors"].get<std::uint64_t>(), 0u);
}

TEST(RingsOrder_test, TheSameOnTheSocketWithTheRingsOff) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    ::setenv("PLEXUS_RINGS", "0", 1);
    run_streams(daemon);
    Client observer({daemon.socket()});
    ::unsetenv("PLEXUS_RINGS");
    EXPECT_EQ(observer.stats()["daemon"]["ring_sessions"].get<std::uint64_t>(), 0u);
}

TEST(RingsOrder_test, SmallRingsCarryLargeFramesInPieces) {
    TempDir dir;
    const auto config = dir.file("plexusd.json");
    std::ofstream(config) << R"({"shm_ring_bytes": 65536, "shm_region_bytes": 0})";
    Daemon daemon(dir, "solo", "", {"--config", config});
    // No shared-memory regions: every large blob goes through the 64 KiB rings as a frame many
    // times their size.
    run_streams(daemon);
}

}  // namespace rings_order_test
}  // namespace plexus::test
