#pragma once
// What the MCAP tests share: a temporary directory, messages to write and compare, a reader of
// every message, and an OutputFile that fails the way full disks and broken devices do.

#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "plexus/mcap/output_file.hpp"
#include "plexus/mcap/reader.hpp"
#include "plexus/mcap/writer.hpp"

namespace plexus::mcap::testing {

/// A directory removed with everything in it at the end of the test.
class TempDir {
public:
    TempDir() {
        std::string pattern = (std::filesystem::temp_directory_path() / "plexus-mcap-XXXXXX").string();
        path_ = ::mkdtemp(pattern.data());
    }
    ~TempDir() { std::filesystem::remove_all(path_); }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    std::string file(const std::string& name) const { return (path_ / name).string(); }

private:
    std::filesystem::path path_;
};

/// A message as written, to compare with what is read back.
struct Message {
    std::uint16_t channel_id = 0;
    std::uint32_t sequence = 0;
    std::uint64_t log_time = 0;
    std::uint64_t publish_time = 0;
    proto::Bytes data;
    bool operator==(const Message&) const = default;
};

inline proto::Bytes random_bytes(std::mt19937& random, std::size_t size) {
    proto::Bytes bytes(size);
    for (auto& byte : bytes)
        byte = static_cast<std::uint8_t>(random());
    return bytes;
}

/// `count` messages over `channels` (ids 1..channels), of random content and sizes up to `max_size`.
inline std::vector<Message> make_messages(std::size_t count, std::uint16_t channels, std::size_t max_size,
                                          std::uint32_t seed = 7) {
    std::mt19937 random(seed);
    std::vector<Message> messages;
    for (std::size_t i = 0; i < count; ++i) {
        Message message;
        message.channel_id = static_cast<std::uint16_t>(1 + i % channels);
        message.sequence = static_cast<std::uint32_t>(i / channels);
        message.log_time = 1'000'000'000 + i * 1000;
        message.publish_time = message.log_time - 17;
        message.data = random_bytes(random, random() % (max_size + 1));
        messages.push_back(std::move(message));
    }
    return messages;
}

/// Every message of the file, or the reader's error.
inline proto::Result<std::vector<Message>> read_all(const Reader& reader,
                                                    const std::set<std::uint16_t>* channels = nullptr) {
    std::vector<Message> messages;
    auto status = reader.for_each_message(
        [&](const MessageView& view) {
            messages.push_back(Message{view.channel_id, view.sequence, view.log_time, view.publish_time,
                                       proto::Bytes(view.data.begin(), view.data.end())});
            return true;
        },
        channels);
    if (!status)
        return status.error();
    return messages;
}

inline proto::Bytes file_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// How a FaultyFile fails.
enum class Fault {
    disk_full,     ///< reserving or writing past `capacity` fails with ENOSPC (writes stop at it)
    no_fallocate,  ///< reserve answers EOPNOTSUPP; writes past `capacity` stop there with ENOSPC
    write_error,   ///< the write number `capacity` (from 0) writes half its bytes and fails with EIO
};

/// A real file that fails on purpose.
class FaultyFile final : public OutputFile {
public:
    FaultyFile(std::unique_ptr<OutputFile> real, Fault fault, std::uint64_t capacity)
        : real_(std::move(real)), fault_(fault), capacity_(capacity) {}

    int write_at(std::uint64_t offset, proto::ByteView bytes) override {
        const std::uint64_t number = writes_++;
        if (fault_ == Fault::write_error) {
            if (number != capacity_)
                return real_->write_at(offset, bytes);
            (void)real_->write_at(offset, bytes.first(bytes.size() / 2));
            return EIO;
        }
        if (offset + bytes.size() <= capacity_)
            return real_->write_at(offset, bytes);
        if (offset < capacity_)
            (void)real_->write_at(offset, bytes.first(static_cast<std::size_t>(capacity_ - offset)));
        return ENOSPC;
    }
    int reserve(std::uint64_t offset, std::uint64_t length) override {
        if (fault_ == Fault::no_fallocate)
            return EOPNOTSUPP;
        if (fault_ == Fault::disk_full && offset + length > capacity_)
            return ENOSPC;
        return 0;  // the real file's space is not taken: the test only checks the writer's logic
    }
    int truncate(std::uint64_t length) override { return real_->truncate(length); }
    int sync() override { return real_->sync(); }
    const std::string& path() const override { return real_->path(); }

private:
    std::unique_ptr<OutputFile> real_;
    Fault fault_;
    std::uint64_t capacity_;
    std::uint64_t writes_ = 0;
};

}  // namespace plexus::mcap::testing
