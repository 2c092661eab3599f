// A damaged MCAP file is refused with an error that names an offset, never read as other data
// and never a crash: every prefix of a small file, and every single-byte change of it.
#include <gtest/gtest.h>

#include <regex>

#include "mcap_test_support.hpp"

namespace plexus::mcap {
namespace {

using testing::Message;

struct SmallFile {
    proto::Bytes bytes;
    std::vector<Message> messages;
};

/// A file of a few chunks, two channels (one with a schema), and metadata; ~2-3 KB.
SmallFile small_file(const std::string& compression, bool summary) {
    testing::TempDir dir;
    const auto path = dir.file("small.mcap");
    SmallFile file;
    file.messages = testing::make_messages(24, 2, 60);
    file.messages[3].data.clear();
    WriterOptions options;
    options.chunk_bytes = 600;
    options.compression = compression;
    options.write_summary = summary;
    auto writer = Writer::create(path, options);
    EXPECT_TRUE(writer);
    const auto schema = (*writer)->add_schema("s", "jsonschema", proto::as_bytes("{}"));
    EXPECT_TRUE((*writer)->add_channel("/a:o", "json", {{"k", "v"}}, schema));
    EXPECT_TRUE((*writer)->add_channel("/b:o", "cbor", {}));
    EXPECT_TRUE((*writer)->write_metadata("m", {{"x", "y"}}));
    for (const auto& message : file.messages)
        EXPECT_TRUE((*writer)->write_message(message.channel_id, message.sequence, message.log_time,
                                             message.publish_time, message.data));
    EXPECT_TRUE((*writer)->close());
    file.bytes = testing::file_bytes(path);
    return file;
}

bool names_an_offset(const std::string& message) {
    return std::regex_search(message, std::regex("^offset [0-9]+: "));
}

TEST(McapDamageTest, EveryTruncationIsAnErrorNamingAnOffset) {
    for (const bool summary : {true, false}) {
        const auto file = small_file("zstd", summary);
        ASSERT_GT(file.bytes.size(), 500u);
        for (std::size_t length = 0; length < file.bytes.size(); ++length) {
            auto reader = Reader::open_bytes(proto::Bytes(file.bytes.begin(), file.bytes.begin() + length));
            ASSERT_FALSE(reader) << "prefix of " << length << " bytes opened";
            ASSERT_TRUE(names_an_offset(reader.error().message)) << length << ": " << reader.error().message;
        }
    }
}

TEST(McapDamageTest, TruncationSaysWhichRecordTheFileEndsIn) {
    const auto file = small_file("zstd", true);
    auto reader = Reader::open_bytes(proto::Bytes(file.bytes.begin(), file.bytes.begin() + 300));
    ASSERT_FALSE(reader);
    EXPECT_TRUE(std::regex_search(reader.error().message,
                                  std::regex("^offset [0-9]+: truncated: the file ends inside a chunk record "
                                             "\\(no footer\\)$")))
        << reader.error().message;
    auto bad = file.bytes;
    bad[0] = 'X';
    EXPECT_EQ(Reader::open_bytes(bad).error().message, "offset 0: not an MCAP file (bad magic)");
}

/// Opens and reads everything; answers whether all of it was accepted, and checks that whatever
/// was accepted is exactly what was written.
bool accepted_unchanged(const proto::Bytes& bytes, const SmallFile& original, const Reader& reference,
                        std::size_t position) {
    auto reader = Reader::open_bytes(bytes);
    if (!reader) {
        EXPECT_TRUE(names_an_offset(reader.error().message)) << position << ": " << reader.error().message;
        return false;
    }
    auto read = testing::read_all(*reader);
    if (!read) {
        EXPECT_TRUE(names_an_offset(read.error().message)) << position << ": " << read.error().message;
        return false;
    }
    EXPECT_EQ(*read, original.messages) << "byte " << position << " changed the messages";
    EXPECT_EQ(reader->channels(), reference.channels()) << "byte " << position;
    EXPECT_EQ(reader->schemas(), reference.schemas()) << "byte " << position;
    EXPECT_EQ(reader->metadata(), reference.metadata()) << "byte " << position;
    EXPECT_EQ(reader->statistics(), reference.statistics()) << "byte " << position;
    EXPECT_EQ(reader->library(), reference.library()) << "byte " << position;
    return true;
}

TEST(McapDamageTest, EverySingleByteChangeIsAnErrorOrChangesNothing) {
    for (const std::string compression : {"zstd", ""}) {
        for (const bool summary : {true, false}) {
            const auto file = small_file(compression, summary);
            auto reference = Reader::open_bytes(file.bytes);
            ASSERT_TRUE(reference) << reference.error().message;
            std::size_t accepted = 0;
            for (std::size_t position = 0; position < file.bytes.size(); ++position) {
                for (const std::uint8_t change : {0x01, 0x80, 0xFF}) {
                    auto bytes = file.bytes;
                    bytes[position] ^= change;
                    accepted += accepted_unchanged(bytes, file, *reference, position) ? 1 : 0;
                }
            }
            // Every byte is under some CRC, except in a file without summary the footer's summary
            // offset start and summary CRC (12 bytes), which a summary start of 0 makes meaningless.
            EXPECT_EQ(accepted, summary ? 0u : 12u * 3)
                << compression << (summary ? " with" : " without") << " summary";
        }
    }
}

TEST(McapDamageTest, LengthsBeyondTheFileAreRefusedWithoutAllocating) {
    const auto file = small_file("zstd", true);
    // The first chunk's length field set to almost 2^64, then to just past the file.
    const std::size_t header_end = 8 + 9 + 4 + 0 + 4 + 6;  // magic, header record ("", "plexus")
    const std::size_t metadata_end = header_end + 9 + (4 + 1) + (4 + 8 + 1 + 1);
    ASSERT_EQ(file.bytes[metadata_end], 0x06) << "expected the first chunk after the metadata";
    for (const std::uint64_t length : {~std::uint64_t{0}, std::uint64_t{file.bytes.size()}}) {
        auto bytes = file.bytes;
        for (std::size_t i = 0; i < 8; ++i)
            bytes[metadata_end + 1 + i] = static_cast<std::uint8_t>(length >> (8 * i));
        auto reader = Reader::open_bytes(bytes);
        ASSERT_TRUE(reader);  // the summary does not depend on the data section's lengths
        auto read = testing::read_all(*reader);
        ASSERT_FALSE(read);
        EXPECT_TRUE(names_an_offset(read.error().message)) << read.error().message;
    }
}

}  // namespace
}  // namespace plexus::mcap
