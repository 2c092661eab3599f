// A disk that fills up (or a device that fails) during a recording leaves a valid MCAP file
// holding every message the writer did not count lost.
#include <gtest/gtest.h>

#include "mcap_test_support.hpp"

namespace plexus::mcap {
namespace {

using testing::Fault;
using testing::FaultyFile;
using testing::Message;

struct Outcome {
    bool created = false;
    std::string create_error;
    proto::Status close_status = proto::Ok{};
    bool file_valid = false;
    std::string error;
    std::uint64_t lost_messages = 0;
    std::uint64_t lost_bytes = 0;
    std::uint64_t written = 0;
};

Outcome record(const std::string& path, Fault fault, std::uint64_t capacity,
               const std::vector<Message>& messages) {
    Outcome outcome;
    auto real = create_output_file(path);
    EXPECT_TRUE(real);
    WriterOptions options;
    options.chunk_bytes = 16 * 1024;
    auto writer = Writer::create_on(std::make_unique<FaultyFile>(std::move(*real), fault, capacity), options);
    if (!writer) {
        outcome.create_error = writer.error().message;
        return outcome;
    }
    outcome.created = true;
    EXPECT_TRUE((*writer)->add_channel("/a:o", "raw", {{"port", "/a:o"}}));
    EXPECT_TRUE((*writer)->add_channel("/b:o", "raw", {}));
    EXPECT_TRUE((*writer)->write_metadata("start", {{"k", "v"}}));
    for (const auto& message : messages)
        (void)(*writer)->write_message(message.channel_id, message.sequence, message.log_time,
                                       message.publish_time, message.data);
    outcome.close_status = (*writer)->close();
    outcome.file_valid = (*writer)->file_valid();
    outcome.error = (*writer)->error();
    outcome.lost_messages = (*writer)->lost_messages();
    outcome.lost_bytes = (*writer)->lost_bytes();
    outcome.written = (*writer)->messages_written();
    return outcome;
}

/// The file holds exactly the messages not counted lost: the first ones, since nothing is
/// written after the first failure.
void expect_kept_all_but_lost(const std::string& path, const Outcome& outcome,
                              const std::vector<Message>& messages) {
    ASSERT_EQ(outcome.written + outcome.lost_messages, messages.size());
    auto reader = Reader::open(path);
    ASSERT_TRUE(reader) << reader.error().message;
    auto read = testing::read_all(*reader);
    ASSERT_TRUE(read) << read.error().message;
    ASSERT_EQ(read->size(), outcome.written);
    EXPECT_TRUE(std::equal(read->begin(), read->end(), messages.begin()));
    EXPECT_EQ(reader->statistics().message_count, outcome.written);
    std::uint64_t lost_bytes = 0;
    for (std::size_t i = read->size(); i < messages.size(); ++i)
        lost_bytes += messages[i].data.size();
    EXPECT_EQ(outcome.lost_bytes, lost_bytes);
    ASSERT_EQ(reader->metadata().size(), 1u);
}

// 3000 incompressible messages of up to 400 bytes: about 650 KB of chunks.
const std::vector<Message>& messages() {
    static const auto made = testing::make_messages(3000, 2, 400);
    return made;
}

TEST(McapDiskFullTest, ReserveFailureLeavesAValidFileOfTheMessagesNotLost) {
    for (const std::uint64_t capacity :
         {std::uint64_t{90'000}, std::uint64_t{150'000}, std::uint64_t{400'000}, std::uint64_t{700'000}}) {
        testing::TempDir dir;
        const auto path = dir.file("full.mcap");
        const auto outcome = record(path, Fault::disk_full, capacity, messages());
        ASSERT_TRUE(outcome.created) << outcome.create_error;
        ASSERT_FALSE(outcome.close_status) << "capacity " << capacity;
        EXPECT_TRUE(outcome.file_valid);
        EXPECT_EQ(outcome.error.rfind("disk full at offset ", 0), 0u) << outcome.error;
        EXPECT_GT(outcome.lost_messages, 0u);
        EXPECT_LE(std::filesystem::file_size(path), capacity);
        expect_kept_all_but_lost(path, outcome, messages());
    }
}

TEST(McapDiskFullTest, NothingLostWhenTheDiskIsLargeEnough) {
    testing::TempDir dir;
    const auto path = dir.file("fits.mcap");
    const auto outcome = record(path, Fault::disk_full, 100'000'000, messages());
    ASSERT_TRUE(outcome.close_status) << outcome.close_status.error().message;
    EXPECT_EQ(outcome.lost_messages, 0u);
    expect_kept_all_but_lost(path, outcome, messages());
}

TEST(McapDiskFullTest, CreateFailsCleanlyWhenNotEvenTheReserveFits) {
    testing::TempDir dir;
    const auto outcome = record(dir.file("tiny.mcap"), Fault::disk_full, 1000, messages());
    EXPECT_FALSE(outcome.created);
    EXPECT_EQ(outcome.create_error.rfind("disk full at offset 0: ", 0), 0u) << outcome.create_error;
}

TEST(McapDiskFullTest, WithoutFallocateAFailedWriteIsOverwrittenByTheEndOfTheFile) {
    // No reserve: the chunk that hits the limit is written in part; the summary goes over it, and
    // fits here because a summary is far smaller than a chunk.
    for (const std::uint64_t capacity : {std::uint64_t{50'000}, std::uint64_t{333'333}}) {
        testing::TempDir dir;
        const auto path = dir.file("no-fallocate.mcap");
        const auto outcome = record(path, Fault::no_fallocate, capacity, messages());
        ASSERT_TRUE(outcome.created);
        ASSERT_FALSE(outcome.close_status);
        ASSERT_TRUE(outcome.file_valid) << outcome.error;
        EXPECT_EQ(outcome.error.rfind("disk full at offset ", 0), 0u) << outcome.error;
        expect_kept_all_but_lost(path, outcome, messages());
    }
}

TEST(McapDiskFullTest, AnIoErrorStopsTheRecordingAndKeepsTheFileValid) {
    for (const std::uint64_t failing_write : {std::uint64_t{2}, std::uint64_t{5}, std::uint64_t{20}}) {
        testing::TempDir dir;
        const auto path = dir.file("eio.mcap");
        const auto outcome = record(path, Fault::write_error, failing_write, messages());
        ASSERT_TRUE(outcome.created);
        ASSERT_FALSE(outcome.close_status);
        ASSERT_TRUE(outcome.file_valid) << outcome.error;
        EXPECT_EQ(outcome.error.rfind("write failed at offset ", 0), 0u) << outcome.error;
        EXPECT_NE(outcome.error.find("Input/output error"), std::string::npos) << outcome.error;
        expect_kept_all_but_lost(path, outcome, messages());
    }
}

}  // namespace
}  // namespace plexus::mcap
