#include "input_source.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace plexus::mcap {

namespace {

class FileSource final : public InputSource {
public:
    FileSource(int fd, std::uint64_t size) : fd_(fd), size_(size) {}
    ~FileSource() override { ::close(fd_); }
    FileSource(const FileSource&) = delete;
    FileSource& operator=(const FileSource&) = delete;

    std::uint64_t size() const override { return size_; }

    proto::Status read(std::uint64_t offset, std::span<std::uint8_t> out) const override {
        std::size_t done = 0;
        while (done < out.size()) {
            const ssize_t got =
                ::pread(fd_, out.data() + done, out.size() - done, static_cast<off_t>(offset + done));
            if (got < 0 && errno == EINTR)
                continue;
            if (got < 0)
                return proto::Error{"offset " + std::to_string(offset + done) +
                                    ": read failed: " + std::strerror(errno)};
            if (got == 0)  // the file shrank since it was opened
                return proto::Error{"offset " + std::to_string(offset + done) + ": the file ends early"};
            done += static_cast<std::size_t>(got);
        }
        return proto::Ok{};
    }

private:
    int fd_;
    std::uint64_t size_;
};

class MemorySource final : public InputSource {
public:
    explicit MemorySource(proto::Bytes bytes) : bytes_(std::move(bytes)) {}
    std::uint64_t size() const override { return bytes_.size(); }
    proto::Status read(std::uint64_t offset, std::span<std::uint8_t> out) const override {
        if (offset > bytes_.size() || out.size() > bytes_.size() - offset)
            return proto::Error{"offset " + std::to_string(offset) + ": read past the end"};
        if (out.empty())
            return proto::Ok{};  // memcpy's pointers may not be null, even for 0 bytes
        std::memcpy(out.data(), bytes_.data() + offset, out.size());
        return proto::Ok{};
    }

private:
    proto::Bytes bytes_;
};

}  // namespace

proto::Result<std::unique_ptr<InputSource>> open_file_source(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return proto::Error{"cannot open " + path + ": " + std::strerror(errno)};
    struct stat status {};
    if (::fstat(fd, &status) != 0 || !S_ISREG(status.st_mode)) {
        ::close(fd);
        return proto::Error{"cannot read " + path + ": not a regular file"};
    }
    return std::unique_ptr<InputSource>(
        std::make_unique<FileSource>(fd, static_cast<std::uint64_t>(status.st_size)));
}

std::unique_ptr<InputSource> memory_source(proto::Bytes bytes) {
    return std::make_unique<MemorySource>(std::move(bytes));
}

proto::Status read_bytes(const InputSource& source, std::uint64_t offset, std::uint64_t length,
                         proto::Bytes& out) {
    out.resize(static_cast<std::size_t>(length));
    return source.read(offset, out);
}

}  // namespace plexus::mcap
