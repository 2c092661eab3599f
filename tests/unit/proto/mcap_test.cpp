// The MCAP writer and reader together: what is written comes back byte for byte, with the
// channels, schemas, metadata and statistics the summary promises, and with or without a summary.
#include <gtest/gtest.h>

#include "mcap_test_support.hpp"

namespace plexus::mcap {
namespace {

using testing::Message;
using testing::TempDir;

/// Three channels (the first with a schema), `messages` written in order, and two metadata records.
proto::Status write_file(const std::string& path, const std::vector<Message>& messages,
                         WriterOptions options) {
    auto writer = Writer::create(path, std::move(options));
    if (!writer)
        return writer.error();
    const std::string schema_text = R"({"type":"object"})";
    const std::uint16_t schema =
        (*writer)->add_schema("plexus.Pose", "jsonschema", proto::as_bytes(schema_text));
    EXPECT_EQ(schema, 1);
    EXPECT_EQ(*(*writer)->add_channel("/robot/pose:o", "json",
                                      {{"carrier", "tcp"}, {"port", "/robot/pose:o"}}, schema),
              1);
    EXPECT_EQ(*(*writer)->add_channel("/camera/image:o", "cbor", {}), 2);
    EXPECT_EQ(*(*writer)->add_channel("/empty:o", "", {{"", ""}}), 3);
    if (auto status = (*writer)->write_metadata("recording", {{"started_by", "test"}, {"host", "here"}});
        !status)
        return status;
    for (const auto& message : messages) {
        if (auto status = (*writer)->write_message(message.channel_id, message.sequence, message.log_time,
                                                   message.publish_time, message.data);
            !status)
            return status;
    }
    if (auto status = (*writer)->write_metadata("end", {}); !status)
        return status;
    return (*writer)->close();
}

std::vector<Message> mixed_messages() {
    // Small messages of every size up to 300 bytes, a 0-byte one and a 6 MB one among them.
    auto messages = testing::make_messages(3000, 3, 300);
    std::mt19937 random(3);
    messages[10].data.clear();
    messages[1500].data = testing::random_bytes(random, 6 * 1024 * 1024);
    messages[1501].data.assign(5 * 1024 * 1024, 0x42);  // compresses well
    return messages;
}

TEST(McapTest, RoundTripsEveryMessageByteForByte) {
    TempDir dir;
    const auto messages = mixed_messages();
    for (const std::string compression : {"zstd", ""}) {
        const auto path = dir.file("round-trip-" + compression + ".mcap");
        WriterOptions options;
        options.compression = compression;
        options.chunk_bytes = 64 * 1024;
        ASSERT_TRUE(write_file(path, messages, options));

        auto reader = Reader::open(path);
        ASSERT_TRUE(reader) << reader.error().message;
        EXPECT_TRUE(reader->has_summary());
        EXPECT_EQ(reader->library(), "plexus");
        EXPECT_EQ(reader->profile(), "");
        auto read = testing::read_all(*reader);
        ASSERT_TRUE(read) << read.error().message;
        ASSERT_EQ(read->size(), messages.size());
        for (std::size_t i = 0; i < messages.size(); ++i)
            ASSERT_EQ((*read)[i], messages[i]) << "message " << i;
    }
}

TEST(McapTest, SplitsChunksAtTheChunkSizeAndGivesBigMessagesTheirOwn) {
    TempDir dir;
    const auto path = dir.file("chunks.mcap");
    const auto messages = mixed_messages();
    WriterOptions options;
    options.chunk_bytes = 64 * 1024;
    ASSERT_TRUE(write_file(path, messages, options));
    auto reader = Reader::open(path);
    ASSERT_TRUE(reader) << reader.error().message;
    // ~3000 * 180 bytes in 64 KiB chunks, plus one chunk for each big message.
    EXPECT_GE(reader->chunk_count(), 8u);
    EXPECT_LE(reader->chunk_count(), 14u);
    EXPECT_LT(reader->file_size(), 8u * 1024 * 1024);  // the 5 MB run of 0x42 was compressed
}

TEST(McapTest, SummaryDescribesChannelsSchemasMetadataAndStatistics) {
    TempDir dir;
    const auto path = dir.file("summary.mcap");
    const auto messages = testing::make_messages(500, 3, 100);
    WriterOptions options;
    options.chunk_bytes = 4096;
    ASSERT_TRUE(write_file(path, messages, options));
    auto reader = Reader::open(path);
    ASSERT_TRUE(reader) << reader.error().message;

    ASSERT_EQ(reader->channels().size(), 3u);
    const Channel& pose = reader->channels().at(1);
    EXPECT_EQ(pose.topic, "/robot/pose:o");
    EXPECT_EQ(pose.message_encoding, "json");
    EXPECT_EQ(pose.schema_id, 1);
    EXPECT_EQ(pose.metadata, (StringMap{{"carrier", "tcp"}, {"port", "/robot/pose:o"}}));
    EXPECT_EQ(reader->channels().at(3).metadata, (StringMap{{"", ""}}));
    ASSERT_EQ(reader->schemas().size(), 1u);
    EXPECT_EQ(reader->schemas().at(1).name, "plexus.Pose");
    EXPECT_EQ(proto::as_string_view(reader->schemas().at(1).data), R"({"type":"object"})");

    ASSERT_EQ(reader->metadata().size(), 2u);
    EXPECT_EQ(reader->metadata()[0], (Metadata{"recording", {{"started_by", "test"}, {"host", "here"}}}));
    EXPECT_EQ(reader->metadata()[1], (Metadata{"end", {}}));

    const Statistics& statistics = reader->statistics();
    EXPECT_EQ(statistics.message_count, 500u);
    EXPECT_EQ(statistics.channel_count, 3u);
    EXPECT_EQ(statistics.schema_count, 1u);
    EXPECT_EQ(statistics.metadata_count, 2u);
    EXPECT_EQ(statistics.chunk_count, reader->chunk_count());
    EXPECT_GT(statistics.chunk_count, 5u);
    EXPECT_EQ(statistics.message_start_time, messages.front().log_time);
    EXPECT_EQ(statistics.message_end_time, messages.back().log_time);
    EXPECT_EQ(statistics.channel_message_counts,
              (std::map<std::uint16_t, std::uint64_t>{{1, 167}, {2, 167}, {3, 166}}));
}

TEST(McapTest, ReadsOnlyTheChannelsAskedForAndStopsWhenTold) {
    TempDir dir;
    const auto path = dir.file("filter.mcap");
    const auto messages = testing::make_messages(900, 3, 100);
    WriterOptions options;
    options.chunk_bytes = 2048;
    ASSERT_TRUE(write_file(path, messages, options));
    auto reader = Reader::open(path);
    ASSERT_TRUE(reader);

    const std::set<std::uint16_t> wanted{2};
    auto read = testing::read_all(*reader, &wanted);
    ASSERT_TRUE(read) << read.error().message;
    std::vector<Message> expected;
    for (const auto& message : messages)
        if (message.channel_id == 2)
            expected.push_back(message);
    EXPECT_EQ(*read, expected);

    std::size_t seen = 0;
    ASSERT_TRUE(reader->for_each_message([&](const MessageView&) { return ++seen < 10; }));
    EXPECT_EQ(seen, 10u);
}

TEST(McapTest, FileWithoutSummaryIsScannedForTheSameFacts) {
    TempDir dir;
    const auto messages = testing::make_messages(400, 3, 100);
    WriterOptions options;
    options.chunk_bytes = 4096;
    ASSERT_TRUE(write_file(dir.file("with.mcap"), messages, options));
    options.write_summary = false;
    ASSERT_TRUE(write_file(dir.file("without.mcap"), messages, options));

    auto with = Reader::open(dir.file("with.mcap"));
    auto without = Reader::open(dir.file("without.mcap"));
    ASSERT_TRUE(with && without) << (without ? "" : without.error().message);
    EXPECT_FALSE(without->has_summary());
    EXPECT_EQ(without->channels(), with->channels());
    EXPECT_EQ(without->schemas(), with->schemas());
    EXPECT_EQ(without->metadata(), with->metadata());
    EXPECT_EQ(without->statistics(), with->statistics());
    auto read = testing::read_all(*without);
    ASSERT_TRUE(read) << read.error().message;
    EXPECT_EQ(*read, messages);
}

TEST(McapTest, EmptyRecordingIsAValidFile) {
    TempDir dir;
    const auto path = dir.file("empty.mcap");
    {
        auto writer = Writer::create(path);
        ASSERT_TRUE(writer);
        ASSERT_TRUE((*writer)->add_channel("/never:o", "json", {}));
        ASSERT_TRUE((*writer)->close());
        EXPECT_TRUE((*writer)->file_valid());
    }
    auto reader = Reader::open(path);
    ASSERT_TRUE(reader) << reader.error().message;
    EXPECT_EQ(reader->statistics().message_count, 0u);
    EXPECT_EQ(reader->chunk_count(), 0u);
    // A channel that never carried a message has no record in the data section, so none in the summary.
    EXPECT_TRUE(reader->channels().empty());
    auto read = testing::read_all(*reader);
    ASSERT_TRUE(read);
    EXPECT_TRUE(read->empty());
}

TEST(McapTest, FlushChunkWritesWhatIsBufferedNow) {
    TempDir dir;
    const auto path = dir.file("flush.mcap");
    auto writer = Writer::create(path);
    ASSERT_TRUE(writer);
    const auto channel = (*writer)->add_channel("/slow:o", "json", {});
    ASSERT_TRUE(channel);
    ASSERT_TRUE((*writer)->write_message(*channel, 0, 5, 5, proto::as_bytes("{}")));
    EXPECT_EQ((*writer)->messages_written(), 0u);
    const auto before = (*writer)->bytes_written();
    ASSERT_TRUE((*writer)->flush_chunk());
    EXPECT_EQ((*writer)->messages_written(), 1u);
    EXPECT_EQ((*writer)->chunks_written(), 1u);
    EXPECT_GT((*writer)->bytes_written(), before);
    EXPECT_EQ(std::filesystem::file_size(path), (*writer)->bytes_written());
    ASSERT_TRUE((*writer)->flush_chunk());  // nothing buffered: no empty chunk
    EXPECT_EQ((*writer)->chunks_written(), 1u);
}

TEST(McapTest, CreateRefusesAnExistingFile) {
    TempDir dir;
    const auto path = dir.file("exists.mcap");
    { std::ofstream(path) << "precious"; }
    auto writer = Writer::create(path);
    ASSERT_FALSE(writer);
    EXPECT_NE(writer.error().message.find(path), std::string::npos) << writer.error().message;
    EXPECT_NE(writer.error().message.find("exists"), std::string::npos) << writer.error().message;
    EXPECT_EQ(testing::file_bytes(path),
              proto::Bytes(proto::as_bytes("precious").begin(), proto::as_bytes("precious").end()));
}

TEST(McapTest, WriterRejectsUnknownChannelsSchemasAndCompression) {
    TempDir dir;
    WriterOptions lz4;
    lz4.compression = "lz4";
    EXPECT_FALSE(Writer::create(dir.file("lz4.mcap"), lz4));
    EXPECT_FALSE(std::filesystem::exists(dir.file("lz4.mcap")));
    auto writer = Writer::create(dir.file("w.mcap"));
    ASSERT_TRUE(writer);
    EXPECT_FALSE((*writer)->add_channel("/a:o", "json", {}, 9));
    EXPECT_FALSE((*writer)->write_message(4, 0, 0, 0, {}));
    ASSERT_TRUE((*writer)->close());
    EXPECT_FALSE((*writer)->write_message(1, 0, 0, 0, {}));
}

TEST(McapTest, OpenNamesTheFileAndTheProblem) {
    TempDir dir;
    EXPECT_FALSE(Reader::open(dir.file("missing.mcap")));
    const auto path = dir.file("text.mcap");
    { std::ofstream(path) << "this is not a recording at all, just text"; }
    auto reader = Reader::open(path);
    ASSERT_FALSE(reader);
    EXPECT_EQ(reader.error().message, path + ": offset 0: not an MCAP file (bad magic)");
}

}  // namespace
}  // namespace plexus::mcap

namespace plexus::mcap {
namespace {

/// Little-endian fields and records by hand, for files our writer does not make.
struct HandMadeFile {
    proto::Bytes bytes{0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
    void u16(std::uint16_t value) { number(value, 2); }
    void u32(std::uint32_t value) { number(value, 4); }
    void u64(std::uint64_t value) { number(value, 8); }
    void string(std::string_view text) {
        u32(static_cast<std::uint32_t>(text.size()));
        bytes.insert(bytes.end(), text.begin(), text.end());
    }
    void number(std::uint64_t value, int width) {
        for (int i = 0; i < width; ++i)
            bytes.push_back(static_cast<std::uint8_t>(value >> (8 * i)));
    }
    /// A record whose content `fill` appends.
    template <typename Fill>
    void record(std::uint8_t opcode, Fill fill) {
        bytes.push_back(opcode);
        const std::size_t length_at = bytes.size();
        u64(0);
        fill();
        const std::uint64_t length = bytes.size() - length_at - 8;
        for (int i = 0; i < 8; ++i)
            bytes[length_at + i] = static_cast<std::uint8_t>(length >> (8 * i));
    }
};

TEST(McapTest, ReadsMessagesOutsideChunksAndSkipsUnknownRecords) {
    // As the spec allows: Channel and Message records straight in the data section, an
    // application's own record (opcode 0x80), DataEnd without CRC, no summary.
    HandMadeFile file;
    file.record(0x01, [&] {
        file.string("x-test");
        file.string("by hand");
    });
    file.record(0x04, [&] {
        file.u16(7);
        file.u16(0);
        file.string("/loose:o");
        file.string("text");
        file.u32(0);  // empty metadata map
    });
    for (std::uint32_t sequence = 0; sequence < 3; ++sequence) {
        file.record(0x05, [&] {
            file.u16(7);
            file.u32(sequence);
            file.u64(100 + sequence);
            file.u64(90 + sequence);
            file.string("payload");  // its u32 length prefix becomes part of the data: 11 bytes
        });
        file.record(0x80, [&] { file.u64(42); });
    }
    file.record(0x0F, [&] { file.u32(0); });
    file.record(0x02, [&] {
        file.u64(0);
        file.u64(0);
        file.u32(0);
    });
    file.bytes.insert(file.bytes.end(), {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'});

    auto reader = Reader::open_bytes(file.bytes);
    ASSERT_TRUE(reader) << reader.error().message;
    EXPECT_EQ(reader->profile(), "x-test");
    ASSERT_EQ(reader->channels().count(7), 1u);
    EXPECT_EQ(reader->channels().at(7).topic, "/loose:o");
    EXPECT_EQ(reader->statistics().message_count, 3u);
    EXPECT_EQ(reader->statistics().message_start_time, 100u);
    EXPECT_EQ(reader->statistics().message_end_time, 102u);
    EXPECT_EQ(reader->chunk_count(), 0u);
    auto read = testing::read_all(*reader);
    ASSERT_TRUE(read) << read.error().message;
    ASSERT_EQ(read->size(), 3u);
    for (std::uint32_t i = 0; i < 3; ++i) {
        EXPECT_EQ((*read)[i].sequence, i);
        EXPECT_EQ((*read)[i].publish_time, 90 + i);
        EXPECT_EQ((*read)[i].data.size(), 11u);
    }
}

}  // namespace
}  // namespace plexus::mcap
