#include "plexus/mcap/output_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace plexus::mcap {

namespace {

class PosixOutputFile final : public OutputFile {
public:
    PosixOutputFile(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
    ~PosixOutputFile() override { ::close(fd_); }
    PosixOutputFile(const PosixOutputFile&) = delete;
    PosixOutputFile& operator=(const PosixOutputFile&) = delete;

    int write_at(std::uint64_t offset, proto::ByteView bytes) override {
        while (!bytes.empty()) {
            const ssize_t written = ::pwrite(fd_, bytes.data(), bytes.size(), static_cast<off_t>(offset));
            if (written < 0) {
                if (errno == EINTR)
                    continue;
                return errno;
            }
            // A short write means the next one will say why (ENOSPC, EFBIG ...).
            bytes = bytes.subspan(static_cast<std::size_t>(written));
            offset += static_cast<std::uint64_t>(written);
        }
        return 0;
    }

    int reserve(std::uint64_t offset, std::uint64_t length) override {
        if (::fallocate(fd_, FALLOC_FL_KEEP_SIZE, static_cast<off_t>(offset), static_cast<off_t>(length)) !=
            0)
            return errno;
        return 0;
    }

    int truncate(std::uint64_t length) override {
        return ::ftruncate(fd_, static_cast<off_t>(length)) == 0 ? 0 : errno;
    }

    int sync() override { return ::fdatasync(fd_) == 0 ? 0 : errno; }

    const std::string& path() const override { return path_; }

private:
    int fd_;
    std::string path_;
};

}  // namespace

proto::Result<std::unique_ptr<OutputFile>> create_output_file(const std::string& path) {
    // O_EXCL: a recording never replaces a file, least of all an earlier recording.
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) {
        const int error = errno;
        if (error == EEXIST)
            return proto::Error{"cannot create " + path +
                                ": the file exists (a recording never replaces a file)"};
        return proto::Error{"cannot create " + path + ": " + std::strerror(error)};
    }
    return std::unique_ptr<OutputFile>(std::make_unique<PosixOutputFile>(fd, path));
}

}  // namespace plexus::mcap
