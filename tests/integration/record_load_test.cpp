// Recording under load (docs/RECORDING.md): a port receiving 1 kHz x 64 B and 30 Hz x 6 MB at
// once for 60 s loses nothing unaccounted for; a disk that fills ends the recording with a clear
// error, leaves a valid file, and leaves the data path alone.
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <filesystem>
#include <thread>

#include "harness.hpp"
#include "plexus/client.hpp"
#include "plexus/recording.hpp"

namespace plexus::test {
namespace record_load_test {

/// Bytes zstd cannot shrink at all.
std::vector<std::uint8_t> random_bytes(std::size_t size) {
    std::vector<std::uint8_t> bytes(size);
    std::uint64_t state = 0x9e3779b97f4a7c15ull;
    for (auto& byte : bytes) {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        byte = static_cast<std::uint8_t>(state);
    }
    return bytes;
}

/// Bytes like a camera image's: one in eight random, the rest a gradient. zstd shrinks them to
/// about a third, so 60 s at 30 Hz x 6 MB leave a few GB on the test machine's disk, not 11.
std::vector<std::uint8_t> image_like_bytes(std::size_t size) {
    auto bytes = random_bytes(size);
    for (std::size_t i = 0; i < size; ++i) {
        if (i % 8 != 0)
            bytes[i] = static_cast<std::uint8_t>(i / 4096);
    }
    return bytes;
}

/// A reader of /load/in on a thread of its own, counting what it gets.
class CountingReader {
public:
    explicit CountingReader(const Daemon& daemon)
        : client_(Client::Options{daemon.socket()}), port_(client_.open("/load/in")) {
        thread_ = std::thread([this] {
            while (!stop_.load()) {
                if (auto got = port_.read(std::chrono::milliseconds(100))) {
                    if (got->data.is_binary())
                        recycle_blob(std::move(got->data.get_binary()));
                    ++count_;
                }
            }
        });
    }
    ~CountingReader() {
        stop_.store(true);
        thread_.join();
    }
    std::uint64_t count() const { return count_.load(); }

private:
    Client client_;
    Port port_;
    std::atomic<bool> stop_{false};
    std::atomic<std::uint64_t> count_{0};
    std::thread thread_;
};

/// Writes `size`-byte blobs on `port` (connected to /load/in) at `hz` until stopped.
class PacedWriter {
public:
    PacedWriter(const Daemon& daemon, const std::string& port, std::size_t size, double hz)
        : client_(Client::Options{daemon.socket()}),
          port_(client_.open(port)),
          blob_(image_like_bytes(size)) {
        client_.connect(port, "/load/in", "local");
        thread_ = std::thread([this, hz] {
            const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                std::chrono::duration<double>(1.0 / hz));
            auto next = std::chrono::steady_clock::now();
            while (!stop_.load()) {
                blob_[0] = static_cast<std::uint8_t>(written_.load());
                port_.write_blob({}, blob_);
                ++written_;
                next += period;
                std::this_thread::sleep_until(next);  // pacing the load, not waiting for an outcome
            }
        });
    }
    void stop() {
        stop_.store(true);
        if (thread_.joinable())
            thread_.join();
    }
    ~PacedWriter() { stop(); }
    std::uint64_t written() const { return written_.load(); }

private:
    Client client_;
    Port port_;
    std::vector<std::uint8_t> blob_;
    std::atomic<bool> stop_{false};
    std::atomic<std::uint64_t> written_{0};
    std::thread thread_;
};

nlohmann::json last_json_line(const std::string& text) {
    std::string trimmed = text;
    while (!trimmed.empty() && trimmed.back() == '\n')
        trimmed.pop_back();
    const auto newline = trimmed.rfind('\n');
    return nlohmann::json::parse(newline == std::string::npos ? trimmed : trimmed.substr(newline + 1));
}

TEST(Record_load_test, SixtySecondsOfSmallAndLargeMessagesAtOnceLoseNothingUncounted) {
    TempDir dir;
    Daemon daemon(dir, "load");
    CountingReader reader(daemon);
    ASSERT_TRUE(wait_port(dir, daemon, "/load/in"));
    const std::string file = dir.file("load.mcap");
    auto recorder = start_cli(dir, daemon, {"record", "/load/in", "-o", file, "--json"}, "recorder");
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(file); })) << recorder->err();
    std::uint64_t written = 0;
    {
        PacedWriter small(daemon, "/load/small", 64, 1000);
        PacedWriter large(daemon, "/load/large", 6 << 20, 30);
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
        while (std::chrono::steady_clock::now() < until)
            std::this_thread::sleep_for(std::chrono::milliseconds(200));
        small.stop();
        large.stop();
        written = small.written() + large.written();
        std::cout << "written: " << small.written() << " x 64 B, " << large.written() << " x 6 MiB\n";
    }
    ASSERT_TRUE(eventually([&] { return reader.count() >= written; }, 60s))
        << reader.count() << " of " << written;
    recorder->signal(SIGINT);
    ASSERT_EQ(recorder->wait(120s), 0) << recorder->err();
    const auto summary = last_json_line(recorder->out());
    const auto kept = summary["messages"].get<std::uint64_t>();
    const auto lost = summary["lost_messages"].get<std::uint64_t>();
    std::cout << "recorded " << kept << ", lost (counted) " << lost << ", bytes " << summary["bytes"] << '\n';
    EXPECT_EQ(kept + lost, written) << "every message is in the file or counted lost";
    const auto recording = Recording::open(file);
    EXPECT_EQ(recording.message_count(), kept);
}

/// A tmpfs of `megabytes` at `path`, unmounted at the end.
class SmallDisk {
public:
    SmallDisk(const std::string& path, int megabytes) : path_(path) {
        std::filesystem::create_directories(path);
        const std::string options = "size=" + std::to_string(megabytes) + "m";
        mounted_ = ::mount("tmpfs", path.c_str(), "tmpfs", 0, options.c_str()) == 0;
    }
    ~SmallDisk() {
        if (mounted_)
            ::umount2(path_.c_str(), MNT_DETACH);
    }
    bool mounted() const { return mounted_; }

private:
    std::string path_;
    bool mounted_ = false;
};

TEST(Record_load_test, AFullDiskEndsTheRecordingWithAClearErrorAValidFileAndTheDataPathUnharmed) {
    if (::geteuid() != 0)
        GTEST_SKIP() << "mounting a small tmpfs needs root (CI runs as root)";
    TempDir dir;
    SmallDisk disk(dir.file("small"), 16);
    ASSERT_TRUE(disk.mounted()) << "mount tmpfs failed";
    Daemon daemon(dir, "full");
    CountingReader reader(daemon);
    ASSERT_TRUE(wait_port(dir, daemon, "/load/in"));
    const std::string file = dir.file("small") + "/full.mcap";
    auto recorder = start_cli(dir, daemon, {"record", "/load/in", "-o", file}, "recorder");
    ASSERT_TRUE(eventually([&] { return std::filesystem::exists(file); })) << recorder->err();
    Client client(Client::Options{daemon.socket()});
    auto port = client.open("/load/large");
    client.connect("/load/large", "/load/in", "local");
    const std::vector<std::uint8_t> blob = random_bytes(6 << 20);
    for (int i = 0; i < 10; ++i)
        port.write_blob({}, blob);
    // The recording ends by itself: the disk is full.
    ASSERT_TRUE(recorder->wait(60s).has_value()) << "the recording did not end when the disk filled";
    EXPECT_EQ(recorder->wait(1s), 1);
    EXPECT_NE(recorder->err().find("disk full"), std::string::npos) << recorder->err();
    // The data path did not notice: every message reached the reader, and more still do.
    ASSERT_TRUE(eventually([&] { return reader.count() >= 10; })) << reader.count();
    port.write_blob({}, blob);
    ASSERT_TRUE(eventually([&] { return reader.count() >= 11; })) << reader.count();
    // What was written before is a valid recording.
    const auto recording = Recording::open(file);
    const auto kept = recording.message_count();
    EXPECT_GE(kept, 1u);
    EXPECT_LT(kept, 10u);
    std::uint64_t read_back = 0;
    recording.for_each([&](const RecordedMessage& m) {
        EXPECT_EQ(m.payload.size(), blob.size() + 5) << "a CBOR byte string head and the blob";
        ++read_back;
        return true;
    });
    EXPECT_EQ(read_back, kept);
    EXPECT_FALSE(recording.end_note().empty());
}

}  // namespace record_load_test
}  // namespace plexus::test
