// plexusd --threads N: local clients are shared among N data threads, and a connection between
// ports of two threads crosses in mail. Here every connection crosses, fans out, and is held back
// by small strict queues on the other side, while large blobs (which a client writes through
// shared memory, and which are lent across threads: only their place crosses) are mixed with
// small ones: every reader
// must get its streams whole, in order, none lost and none twice. Then the daemon's answers
// (stats, disconnect, a port closed while data crosses) must stay those of one thread.
#include <gtest/gtest.h>

#include <atomic>
#include <cstring>
#include <optional>
#include <thread>

#include "harness.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace threads_test {

constexpr int writers = 3;
constexpr int readers = 3;
constexpr std::uint32_t per_stream = 4000;

std::size_t size_of(std::uint32_t i) {
    return i % 97 == 5 ? 200 * 1024 : 8 + i % 120;  // now and then a blob through shared memory
}

void write_stream(Port& port, int stream) {
    for (std::uint32_t i = 0; i < per_stream; ++i) {
        std::vector<std::uint8_t> bytes(size_of(i));
        fill_stream_bytes(bytes, stream, i);
        port.write(Value::binary(std::move(bytes)), i % 16 == 0 || size_of(i) > 1000);
    }
    port.flush();
}

/// Reads stream `stream` whole from `port`, checking each message; the first problem, or "".
std::string read_stream(Port& port, int stream) {
    std::uint64_t last_seq = 0;
    const std::string name = "stream " + std::to_string(stream) + " at " + port.name();
    for (std::uint32_t i = 0; i < per_stream; ++i) {
        auto message = port.read(std::chrono::seconds(60));
        if (!message)
            return name + ": message " + std::to_string(i) + " never came";
        if (!message->data.is_binary())
            return name + ": message " + std::to_string(i) + " is not a blob";
        std::vector<std::uint8_t> expected(size_of(i));
        fill_stream_bytes(expected, stream, i);
        const auto& got = message->data.get_binary();
        if (got.size() != expected.size() || std::memcmp(got.data(), expected.data(), got.size()) != 0)
            return name + ": message " + std::to_string(i) + " arrived changed or out of order";
        if (last_seq != 0 && message->envelope.seq != last_seq + 1)
            return name + ": seq " + std::to_string(message->envelope.seq) + " after " +
                   std::to_string(last_seq);
        last_seq = message->envelope.seq;
    }
    if (port.read(std::chrono::milliseconds(0)))
        return name + ": a message more than was written";
    return "";
}

TEST(Threads_test, EveryConnectionKeepsItsOrderAcrossDataThreadsUnderBackPressure) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", {"--threads", "3"});
    // Clients go to the data threads in turn: writer w and reader r share a thread only when
    // (w + r) is a multiple of 3 apart; each source fans out to two readers on other threads.
    std::vector<std::unique_ptr<Client>> writing;
    std::vector<std::unique_ptr<Client>> reading;
    for (int n = 0; n < writers; ++n)
        writing.push_back(std::make_unique<Client>(Client::Options{daemon.socket()}));
    for (int n = 0; n < readers; ++n)
        reading.push_back(std::make_unique<Client>(Client::Options{daemon.socket()}));
    struct Stream {
        Port source;
        std::vector<Port> sinks;
    };
    std::vector<Stream> streams;
    PortOptions small{QueuePolicy::strict, 8};
    for (int w = 0; w < writers; ++w) {
        for (int k = 0; k < 2; ++k) {
            const int s = static_cast<int>(streams.size());
            Stream stream{writing[w]->open("/threads/source" + std::to_string(s)), {}};
            for (int r : {(w + 1) % readers, (w + 2) % readers}) {
                stream.sinks.push_back(
                    reading[r]->open("/threads/sink" + std::to_string(s) + "." + std::to_string(r), small));
                writing[w]->connect(stream.source.name(), stream.sinks.back().name());
            }
            streams.push_back(std::move(stream));
        }
    }
    std::vector<std::string> problems(streams.size() * 2);
    {
        std::vector<std::jthread> threads;
        for (std::size_t s = 0; s < streams.size(); ++s) {
            for (std::size_t k = 0; k < 2; ++k) {
                threads.emplace_back([&, s, k] {
                    problems[s * 2 + k] = read_stream(streams[s].sinks[k], static_cast<int>(s));
                });
            }
            threads.emplace_back([&, s] { write_stream(streams[s].source, static_cast<int>(s)); });
        }
    }
    for (const auto& problem : problems)
        EXPECT_EQ(problem, "");

    // The counters of every thread, added up.
    Client observer({daemon.socket()});
    const auto stats = observer.stats();
    const auto& counters = stats["daemon"];
    EXPECT_EQ(counters["sessions_accepted"].get<std::uint64_t>(), writers + readers + 1u);
    EXPECT_EQ(counters["protocol_errors"].get<std::uint64_t>(), 0u);
    // Every blob was lent to both its readers on other threads, none copied, and every slot came
    // back to its writer once both had read it.
    std::uint64_t blobs = 0;
    for (std::uint32_t i = 0; i < per_stream; ++i)
        blobs += size_of(i) > 1000 ? streams.size() : 0;
    EXPECT_EQ(counters["shm_passed"].get<std::uint64_t>(), blobs);
    EXPECT_EQ(counters["shm_copied"].get<std::uint64_t>(), 0u);
    EXPECT_TRUE(eventually([&] { return observer.stats()["daemon"]["shm_slots"].get<std::uint64_t>() == 0; }))
        << "slots still held after every reader read them";
    std::uint64_t delivered = 0;
    for (const auto& port : stats["ports"]) {
        if (port["name"].get<std::string>().rfind("/threads/sink", 0) == 0)
            delivered += port["delivered"].get<std::uint64_t>();
    }
    EXPECT_EQ(delivered, streams.size() * 2 * per_stream);
}

TEST(Threads_test, ConnectionsComeAndGoWhileDataCrossesThreads) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", {"--threads", "2"});
    Client writer({daemon.socket()});
    Client reader({daemon.socket()});   // on the other data thread
    Client control({daemon.socket()});  // asks: the writer's session is held back by a full reader
    std::optional<Port> source = writer.open("/churn/source");
    auto sink = reader.open("/churn/sink", PortOptions{QueuePolicy::strict, 4});
    std::jthread writing([&](std::stop_token stop) {
        std::int64_t i = 0;
        while (!stop.stop_requested())
            source->write(Value(i++), true);
    });
    // Connect and disconnect over and over while the writer writes: whatever arrives, arrives in
    // order, and the daemon answers every request.
    std::int64_t last = -1;
    for (int round = 0; round < 30; ++round) {
        control.connect(source->name(), sink.name());
        for (int n = 0; n < 20; ++n) {
            auto message = sink.read(std::chrono::seconds(30));
            ASSERT_TRUE(message) << "round " << round;
            const auto value = message->data.get<std::int64_t>();
            EXPECT_GT(value, last) << "round " << round;
            last = value;
        }
        control.disconnect(source->name(), sink.name());
    }
    // The writer's port closed while data crosses to its reader: the reader (reading on, or the
    // writer, held back, could not stop) and the daemon go on.
    control.connect(source->name(), sink.name());
    std::atomic<bool> in_order{true};
    std::jthread reading([&](std::stop_token stop) {
        while (!stop.stop_requested()) {
            if (auto message = sink.read(std::chrono::milliseconds(50))) {
                in_order = in_order && message->data.get<std::int64_t>() > last;
                last = message->data.get<std::int64_t>();
            }
        }
    });
    writing = {};  // stops and joins
    source.reset();
    reading = {};
    EXPECT_TRUE(in_order);
    EXPECT_EQ(control.stats()["daemon"]["protocol_errors"].get<std::uint64_t>(), 0u);
}

}  // namespace threads_test
}  // namespace plexus::test
