// Limits agree end to end: a message the daemon cannot take (over its frame limit) or no reader
// could decode (nested too deep) is refused at the writer with a clear error, before anything is
// sent; the writer's session and its other ports carry on; and what is accepted is delivered.
#include <signal.h>

#include <gtest/gtest.h>

#include <fstream>

#include "harness.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace limits_test {

constexpr std::size_t small_frame = 1024 * 1024;

/// A daemon whose frame limit is 1 MiB (the default, 64 MiB, would make these tests slow).
std::vector<std::string> small_frame_config(const TempDir& dir) {
    const std::string config = dir.file("small-frame.json");
    std::ofstream(config) << R"({"max_frame": )" << small_frame << "}\n";
    return {"--config", config};
}

std::string nested(std::size_t depth) {
    return std::string(depth, '[') + "1" + std::string(depth, ']');
}

// `plexus write` of a line over the frame limit used to exit 0 with nothing said, while the
// daemon dropped the writer's whole session; the reader got nothing.
TEST(Limits_test, ALineOverTheFrameLimitIsRefusedByTheWriterAndTheLinesBeforeItArrive) {
    TempDir dir;
    Daemon daemon(dir, "limits", "", small_frame_config(dir));
    auto reader = start_cli(dir, daemon, {"read", "/limits/in", "--count", "2", "--timeout", "60"}, "reader");
    ASSERT_TRUE(wait_port(dir, daemon, "/limits/in"));
    const std::string too_large = "\"" + std::string(small_frame + 10, 'x') + "\"\n";
    auto written = run_cli(dir, daemon, {"write", "/limits/out", "/limits/in"}, "1\n2\n" + too_large + "3\n");
    EXPECT_EQ(written.status, 4);
    EXPECT_NE(written.err.find("line 3"), std::string::npos) << written.err;
    EXPECT_NE(written.err.find("frame limit of " + std::to_string(small_frame)), std::string::npos)
        << written.err;
    ASSERT_EQ(reader->wait(slower(30s)), 0) << reader->err();
    EXPECT_EQ(reader->out(), "1\n2\n");
}

// A component whose one port writes too much keeps its session: its other ports, and that port
// itself, go on. Nothing too large is held for after a reconnection either.
TEST(Limits_test, AMessageOverTheFrameLimitLeavesTheSessionAndItsOtherPortsAlone) {
    TempDir dir;
    Daemon daemon(dir, "limits", "", small_frame_config(dir));
    Client writing({daemon.socket()});
    Client reading({daemon.socket()});
    auto big = writing.open("/limits/big");
    auto calm = writing.open("/limits/calm");
    auto big_in = reading.open("/limits/big_in");
    auto calm_in = reading.open("/limits/calm_in");
    writing.connect("/limits/big", "/limits/big_in");
    writing.connect("/limits/calm", "/limits/calm_in");

    try {
        big.write(Value(std::string(small_frame, 'x')));
        ADD_FAILURE() << "a message over the frame limit was accepted";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::refused);
        EXPECT_NE(std::string(e.what()).find("frame limit"), std::string::npos) << e.what();
    }
    std::vector<std::uint8_t> blob(small_frame + 1, 7);
    EXPECT_THROW(big.write_blob({}, blob), Error);

    calm.write(Value("calm"));
    big.write(Value("small"));
    const auto calm_message = calm_in.read(slower(10s));
    ASSERT_TRUE(calm_message.has_value());
    EXPECT_EQ(calm_message->data, "calm");
    const auto big_message = big_in.read(slower(10s));
    ASSERT_TRUE(big_message.has_value());
    EXPECT_EQ(big_message->data, "small");  // nothing came before it
    EXPECT_EQ(writing.state(), ConnectionState::connected);

    // With the daemon away, it is refused at once, not held to fail at every reconnection.
    daemon.process().signal(SIGKILL);
    ASSERT_TRUE(daemon.process().wait(10s).has_value());
    ASSERT_TRUE(eventually([&] { return writing.state() == ConnectionState::disconnected; }));
    EXPECT_THROW(big.write(Value(std::string(small_frame, 'x'))), Error);
    EXPECT_EQ(big.dropped_while_disconnected(), 0u);
}

// JSON nested ~90,000 levels crashed `plexus write` (recursion in the CBOR encoder); from 129 levels
// up, messages were relayed that no reader could decode (`plexus read` exited 4 and lost the rest).
TEST(Limits_test, ValuesNestedDeeperThanEveryReaderDecodesAreRefusedWhereTheyEnter) {
    TempDir dir;
    Daemon daemon(dir, "limits");
    auto reader = start_cli(dir, daemon, {"read", "/deep/in", "--count", "2", "--timeout", "60"}, "reader");
    ASSERT_TRUE(wait_port(dir, daemon, "/deep/in"));

    for (const std::size_t depth : {129u, 90'000u}) {
        auto written = run_cli(dir, daemon, {"write", "/deep/out", "/deep/in"}, nested(depth) + "\n");
        EXPECT_EQ(written.status, 2) << depth << " levels: " << written.err;
        EXPECT_NE(written.err.find("deeper than 128 levels"), std::string::npos) << written.err;
    }
    // 128 levels is the limit itself: written, relayed and decoded.
    auto written = run_cli(dir, daemon, {"write", "/deep/out", "/deep/in"}, nested(128) + "\n\"after\"\n");
    EXPECT_EQ(written.status, 0) << written.err;
    ASSERT_EQ(reader->wait(slower(30s)), 0) << reader->err();
    EXPECT_EQ(reader->out(), nested(128) + "\n\"after\"\n");

    // A parameter too deep is a usage error at the CLI, and the daemon is unharmed.
    auto set = run_cli(dir, daemon, {"param", "set", "/deep/out", "/deep/in", "k=" + nested(129)});
    EXPECT_EQ(set.status, 2) << set.err;
    EXPECT_NE(set.err.find("deeper than 128 levels"), std::string::npos) << set.err;
    EXPECT_EQ(run_cli(dir, daemon, {"list"}).status, 0);
}

}  // namespace limits_test
}  // namespace plexus::test
