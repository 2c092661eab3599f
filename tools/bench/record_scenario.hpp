#pragma once
// plexus-bench record (issue 28): its three parts, and what they share: where the files go and a
// recording started and stopped through the control protocol, as `plexus record` does.

#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "options.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/operations.hpp"

namespace plexus::bench {

/// Recording throughput against dd into the same directory (record_scenario.cpp).
void measure_record_throughput(const Options& options);
/// Latency and throughput without, with, and again without a recording (record_data_path.cpp).
void measure_record_data_path(const Options& options);
/// `plexus what-if` in recorded messages per second (record_what_if.cpp).
void measure_what_if(const Options& options);

inline std::uint64_t file_size(const std::string& path) {
    struct stat info {};
    return ::stat(path.c_str(), &info) == 0 ? static_cast<std::uint64_t>(info.st_size) : 0;
}

/// An unsigned count from a recorder's status document; 0 if absent.
inline std::uint64_t status_count(const Value& document, const char* key) {
    const auto found = document.find(key);
    return found != document.end() && found->is_number_unsigned() ? found->get<std::uint64_t>() : 0;
}

/// The directory the files go to: --dir, or a fresh one under /tmp removed afterwards.
class OutputDir {
public:
    explicit OutputDir(const std::string& given) {
        if (given.empty()) {
            temporary_ = std::make_unique<TempDir>();
            path_ = temporary_->path();
        } else {
            path_ = std::filesystem::absolute(given).lexically_normal().string();
            std::filesystem::create_directories(path_);
        }
    }
    /// A path in it that no earlier file used (the recorder never overwrites).
    std::string next(const std::string& stem, const std::string& extension) {
        return path_ + "/" + stem + "-" + std::to_string(::getpid()) + "-" + std::to_string(++files_) +
               extension;
    }
    const std::string& path() const { return path_; }

private:
    std::unique_ptr<TempDir> temporary_;
    std::string path_;
    int files_ = 0;
};

/// One recording by the daemon, started on construction; stop() returns once it is closed.
class Recording {
public:
    Recording(Client& control, std::vector<std::string> ports, std::string path)
        : control_(control), path_(std::move(path)) {
        proto::RecordStartRequest asked;
        asked.ports = std::move(ports);
        asked.path = path_;
        id_ = control_.request(asked.encode()).at("id").get<std::uint64_t>();
    }
    ~Recording() {
        if (!stopped_) {
            try {
                stop();
            } catch (...) {
                // The daemon also ends the recording when this client's session closes.
            }
        }
    }
    Recording(const Recording&) = delete;
    Recording& operator=(const Recording&) = delete;

    /// Returns the status document once the daemon has written, synced and closed the file
    /// (record_stop replies only then).
    Value stop() {
        stopped_ = true;
        proto::RecordStopRequest asked;
        asked.id = id_;
        return control_.request(asked.encode());
    }
    const std::string& path() const { return path_; }

private:
    Client& control_;
    std::string path_;
    std::uint64_t id_ = 0;
    bool stopped_ = false;
};

/// Says so on stderr if the recorder kept fewer than `expected` messages or lost any: a
/// benchmark must not hide losses. Returns true if it kept them all.
inline bool check_kept(const Value& status, std::uint64_t expected, const std::string& what) {
    const auto lost = status_count(status, "lost_messages");
    const auto shared = status_count(status, "not_recordable");
    const auto kept = status_count(status, "messages");
    if (lost == 0 && shared == 0 && kept >= expected)
        return true;
    std::cerr << "plexus-bench: " << what << ": the recorder kept " << kept << " of " << expected
              << " messages (lost " << lost << ", not recordable " << shared << "): " << status.dump()
              << '\n';
    return false;
}

}  // namespace plexus::bench
