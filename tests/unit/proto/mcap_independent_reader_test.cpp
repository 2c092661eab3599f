// Files from our Writer read by a reader we did not write: Foxglove's @mcap/core under node
// (tests/mcap/read_mcap.js, vendored packages in tests/mcap/vendor). Every message must come
// back with its channel, sequence, times and a byte-identical payload (compared by SHA-256).
#include <gtest/gtest.h>
#include <openssl/evp.h>

#include <cstdio>
#include <nlohmann/json.hpp>

#include "mcap_test_support.hpp"

namespace plexus::mcap {
namespace {

using testing::Message;

std::string sha256_hex(proto::ByteView data) {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int length = 0;
    EVP_Digest(data.data(), data.size(), digest, &length, EVP_sha256(), nullptr);
    std::string hex;
    for (unsigned int i = 0; i < length; ++i) {
        char pair[3];
        std::snprintf(pair, sizeof pair, "%02x", digest[i]);
        hex += pair;
    }
    return hex;
}

/// Debian's node (/usr/bin/node) first, as scripts/deps installs it; else one on PATH; else "".
std::string find_node() {
    if (::access("/usr/bin/node", X_OK) == 0)
        return "/usr/bin/node";
    const char* path = std::getenv("PATH");
    std::string directories = path != nullptr ? path : "";
    std::size_t start = 0;
    while (start <= directories.size()) {
        const std::size_t end = std::min(directories.find(':', start), directories.size());
        const std::string candidate = directories.substr(start, end - start) + "/node";
        if (end > start && ::access(candidate.c_str(), X_OK) == 0)
            return candidate;
        start = end + 1;
    }
    return "";
}

/// Runs `command` and returns its standard output and exit status.
std::pair<std::string, int> run(const std::string& command) {
    std::string output;
    FILE* pipe = ::popen(command.c_str(), "r");
    if (pipe == nullptr)
        return {"", -1};
    char buffer[65536];
    std::size_t got = 0;
    while ((got = std::fread(buffer, 1, sizeof buffer, pipe)) > 0)
        output.append(buffer, got);
    return {output, ::pclose(pipe)};
}

TEST(McapIndependentReader, FoxgloveReaderReadsEveryMessageByteIdentical) {
    const std::string node = find_node();
    if (node.empty())
        GTEST_SKIP() << "node is not installed (scripts/deps installs Debian's nodejs): the independent "
                        "MCAP reader cannot run";
    testing::TempDir dir;
    const auto path = dir.file("independent.mcap");
    auto messages = testing::make_messages(2000, 3, 500);
    std::mt19937 random(11);
    messages[5].data.clear();
    messages[700].data = testing::random_bytes(random, 6 * 1024 * 1024);  // a chunk of its own
    messages[701].data.assign(3 * 1024 * 1024, 0);                        // compresses to almost nothing
    const std::vector<std::string> topics{"/robot/pose:o", "/camera/image:o", "/log:o"};
    const std::vector<StringMap> metadata{{{"carrier", "tcp"}}, {}, {{"qos", "reliable"}, {"rate", "10"}}};
    {
        WriterOptions options;
        options.chunk_bytes = 256 * 1024;
        auto writer = Writer::create(path, options);
        ASSERT_TRUE(writer);
        for (std::size_t i = 0; i < topics.size(); ++i)
            ASSERT_TRUE((*writer)->add_channel(topics[i], "cbor", metadata[i]));
        ASSERT_TRUE((*writer)->write_metadata("recording", {{"by", "test"}}));
        for (const auto& message : messages)
            ASSERT_TRUE((*writer)->write_message(message.channel_id, message.sequence, message.log_time,
                                                 message.publish_time, message.data));
        ASSERT_TRUE((*writer)->close());
    }

    const auto [output, status] =
        run("'" + node + "' '" PLEXUS_SOURCE_DIR "/tests/mcap/read_mcap.js' '" + path + "' 2>&1");
    ASSERT_EQ(status, 0) << output;

    // @mcap/core yields messages in log time order; ours are written in that order, with
    // distinct log times, so the order must match too.
    std::size_t index = 0;
    std::size_t start = 0;
    while (start < output.size()) {
        const std::size_t end = output.find('\n', start);
        ASSERT_NE(end, std::string::npos) << "unterminated line";
        const auto line = nlohmann::json::parse(output.substr(start, end - start));
        start = end + 1;
        ASSERT_LT(index, messages.size()) << "more messages than written";
        const Message& expected = messages[index];
        const std::size_t channel = expected.channel_id - 1u;
        EXPECT_EQ(line.at("topic"), topics[channel]) << "message " << index;
        EXPECT_EQ(line.at("messageEncoding"), "cbor");
        EXPECT_EQ(line.at("metadata").get<StringMap>(), metadata[channel]) << "message " << index;
        EXPECT_EQ(line.at("channelId"), expected.channel_id);
        EXPECT_EQ(line.at("sequence"), expected.sequence) << "message " << index;
        EXPECT_EQ(line.at("logTime"), std::to_string(expected.log_time)) << "message " << index;
        EXPECT_EQ(line.at("publishTime"), std::to_string(expected.publish_time)) << "message " << index;
        EXPECT_EQ(line.at("length"), expected.data.size()) << "message " << index;
        ASSERT_EQ(line.at("sha256"), sha256_hex(expected.data)) << "message " << index;
        ++index;
    }
    EXPECT_EQ(index, messages.size());
}

}  // namespace
}  // namespace plexus::mcap
