// Data arrives complete, in order and unchanged: through one daemon, and between two over tcp.
#include <gtest/gtest.h>

#include <random>
#include <sstream>

#include "harness.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace transfer_test {

TEST(Transfer_test, TenThousandMessagesThroughOneDaemonArriveInOrder) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    auto reader = start_cli(dir, daemon, {"read", "/sink", "--count", "10000", "--timeout", "60"}, "reader");
    ASSERT_TRUE(wait_port(dir, daemon, "/sink"));

    auto written = run_cli(dir, daemon, {"write", "/source", "/sink"}, numbered_lines(0, 10000));

    ASSERT_EQ(written.status, 0) << written.err;
    ASSERT_EQ(reader->wait(60s), 0) << reader->err();
    EXPECT_EQ(reader->out(), numbered_lines(0, 10000));
    auto stats = run_cli(dir, daemon, {"list"});
    EXPECT_EQ(stats.status, 0);
}

TEST(Transfer_test, TenThousandMessagesOverTcpBetweenTwoDaemonsArriveInOrder) {
    TempDir dir;
    Daemon first(dir, "first");
    Daemon second(dir, "second", first.names());
    auto reader =
        start_cli(dir, second, {"read", "/far/sink", "--count", "10000", "--timeout", "60"}, "reader");
    ASSERT_TRUE(wait_port(dir, first, "/far/sink"));

    auto written = run_cli(dir, first, {"write", "/near/source", "/far/sink"}, numbered_lines(0, 10000));

    ASSERT_EQ(written.status, 0) << written.err;
    ASSERT_EQ(reader->wait(60s), 0) << reader->err();
    EXPECT_EQ(reader->out(), numbered_lines(0, 10000));
}

TEST(Transfer_test, ExplicitTcpCarrierOnOneDaemonGoesThroughTheNetworkPath) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    auto reader = start_cli(dir, daemon, {"read", "/sink", "--count", "3", "--timeout", "30"}, "reader");
    ASSERT_TRUE(wait_port(dir, daemon, "/sink"));
    auto source = start_cli(dir, daemon, {"read", "/source", "--timeout", "30"}, "source-holder");
    ASSERT_TRUE(wait_port(dir, daemon, "/source"));
    // /source is held open by a reader process; connect it with an explicit tcp carrier.
    auto connected = run_cli(dir, daemon, {"connect", "/source", "/sink", "tcp"});
    ASSERT_EQ(connected.status, 0) << connected.err;
    auto stats = run_cli(dir, daemon, {"stats", "/source", "--json"});
    ASSERT_EQ(stats.status, 0) << stats.err;
    auto json = nlohmann::json::parse(stats.out);
    EXPECT_EQ(json["ports"][0]["outgoing"][0]["carrier"], "tcp");
}

TEST(Transfer_test, JsonValuesArriveIdentical) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const std::vector<std::string> values{
        R"({"nested":{"list":[1,-2,3.5,"four",null,true,false],"empty":{},"none":[]}})",
        "-9223372036854775808",
        "18446744073709551615",
        "0.1",
        "1e+300",
        R"("text with \"quotes\" and ünïcödé")",
        "null",
        "true",
        "false",
        R"([[[[]]]])",
        "plain words become a string"};
    std::string input;
    for (const auto& v : values)
        input += v + "\n";
    auto reader =
        start_cli(dir, daemon, {"read", "/sink", "--count", std::to_string(values.size()), "--timeout", "30"},
                  "reader");
    ASSERT_TRUE(wait_port(dir, daemon, "/sink"));

    ASSERT_EQ(run_cli(dir, daemon, {"write", "/source", "/sink"}, input).status, 0);

    ASSERT_EQ(reader->wait(30s), 0) << reader->err();
    std::istringstream lines(reader->out());
    std::string line;
    for (const auto& v : values) {
        ASSERT_TRUE(std::getline(lines, line));
        auto expected = nlohmann::json::parse(v, nullptr, false);
        if (expected.is_discarded())
            expected = v;
        EXPECT_EQ(nlohmann::json::parse(line), expected) << "sent " << v << " got " << line;
    }
}

TEST(Transfer_test, OneMebibyteBlobFromTheLibraryArrivesByteForByte) {
    TempDir dir;
    Daemon first(dir, "first");
    Daemon second(dir, "second", first.names());
    std::vector<std::uint8_t> blob(1 << 20);
    std::mt19937 random(42);
    for (auto& byte : blob)
        byte = static_cast<std::uint8_t>(random());

    Client receiving({second.socket()});
    auto sink = receiving.open("/blob/sink");
    Client sending({first.socket()});
    auto source = sending.open("/blob/source");
    EXPECT_EQ(sending.connect("/blob/source", "/blob/sink"), "tcp");
    source.write(Value{{"image", Value::binary(blob)}, {"width", 1024}});

    auto message = sink.read(30s);

    ASSERT_TRUE(message.has_value());
    EXPECT_EQ(message->envelope.source, "/blob/source");
    EXPECT_EQ(message->envelope.seq, 1u);
    EXPECT_EQ(message->data["width"], 1024);
    ASSERT_TRUE(message->data["image"].is_binary());
    const std::vector<std::uint8_t>& received = message->data["image"].get_binary();
    EXPECT_TRUE(received == blob);
}

TEST(Transfer_test, MessagesLargerThanTheQueueByteBoundStillPassAStrictQueue) {
    // A reader queue holds at most 8 MiB by default: a message larger than that must not wedge it.
    TempDir dir;
    Daemon first(dir, "first");
    Daemon second(dir, "second", first.names());
    Client receiving({second.socket()});
    auto sink = receiving.open("/huge/sink");
    Client sending({first.socket()});
    auto source = sending.open("/huge/source");
    ASSERT_EQ(sending.connect("/huge/source", "/huge/sink"), "tcp");
    std::vector<std::uint8_t> blob(12u << 20);
    std::mt19937 random(3);
    for (auto& byte : blob)
        byte = static_cast<std::uint8_t>(random());
    for (int i = 0; i < 3; ++i) {
        blob[0] = static_cast<std::uint8_t>(i);
        source.write(Value::binary(blob));
    }
    for (int i = 0; i < 3; ++i) {
        auto message = sink.read(60s);
        ASSERT_TRUE(message.has_value()) << "message " << i;
        ASSERT_TRUE(message->data.is_binary());
        blob[0] = static_cast<std::uint8_t>(i);
        const std::vector<std::uint8_t>& received = message->data.get_binary();
        EXPECT_TRUE(received == blob) << "message " << i << " differs";
    }
}

TEST(Transfer_test, MessagesLeftInALinkThatDisconnectDrainsInVainAreCounted) {
    // A remote reader that never reads: the link to it fills, then a disconnect gives the link
    // its grace period to drain, which cannot work. What stays queued is lost, and counted.
    TempDir dir;
    Daemon first(dir, "first");
    Daemon second(dir, "second", first.names());
    Client receiving({second.socket()});
    auto sink = receiving.open("/stuck/sink", {QueuePolicy::strict, 1});
    Client sending({first.socket()});
    auto source = sending.open("/stuck/source");
    ASSERT_EQ(sending.connect("/stuck/source", "/stuck/sink"), "tcp");
    const std::vector<std::uint8_t> blob(64 * 1024, 7);
    for (int i = 0; i < 300; ++i)  // ~19 MiB: more than the sink, the link queue and TCP hold
        source.write(Value::binary(blob), false);
    source.flush();

    auto disconnected = run_cli(dir, first, {"disconnect", "/stuck/source", "/stuck/sink"});
    ASSERT_EQ(disconnected.status, 0) << disconnected.err;

    std::uint64_t lost = 0;
    const auto deadline = std::chrono::steady_clock::now() + 20s;
    while (lost == 0 && std::chrono::steady_clock::now() < deadline) {
        auto stats = run_cli(dir, first, {"stats", "--json"});
        ASSERT_EQ(stats.status, 0) << stats.err;
        lost = nlohmann::json::parse(stats.out)["daemon"].value("dropped_link_down", std::uint64_t{0});
    }
    EXPECT_GT(lost, 0u) << "the messages the link could not deliver were not counted";
}

TEST(Transfer_test, AStreamMixingLargeAndSmallMessagesArrivesWholeAndInOrder) {
    // The large ones are received straight into their messages (client/src/large_payload.hpp),
    // the small ones through the receive buffer: the start of a large frame arrives in that
    // buffer after small frames, and small frames follow it in the same socket reads.
    TempDir dir;
    Daemon daemon(dir, "solo");
    Client receiving({daemon.socket()});
    auto sink = receiving.open("/mix/sink");
    Client sending({daemon.socket()});
    auto source = sending.open("/mix/source");
    ASSERT_EQ(sending.connect("/mix/source", "/mix/sink"), "local");
    std::mt19937 random(7);
    std::vector<std::vector<std::uint8_t>> sent;
    for (int i = 0; i < 40; ++i) {
        const std::size_t size = i % 3 == 0 ? 300 * 1024 + i : 16 + i;
        std::vector<std::uint8_t> blob(size);
        for (auto& byte : blob)
            byte = static_cast<std::uint8_t>(random());
        source.write(Value::binary(blob), i % 7 == 6);
        sent.push_back(std::move(blob));
    }
    source.flush();
    for (std::size_t i = 0; i < sent.size(); ++i) {
        auto message = sink.read(30s);
        ASSERT_TRUE(message.has_value()) << "message " << i;
        EXPECT_EQ(message->envelope.seq, i + 1);
        EXPECT_EQ(message->envelope.source, "/mix/source");
        ASSERT_TRUE(message->data.is_binary());
        const std::vector<std::uint8_t>& received = message->data.get_binary();
        EXPECT_TRUE(received == sent[i]) << "message " << i << " differs";
    }
}

}  // namespace transfer_test
}  // namespace plexus::test
