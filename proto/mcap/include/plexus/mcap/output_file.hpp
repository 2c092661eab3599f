#pragma once
// The few file operations the MCAP writer needs, behind an interface so that tests can make
// them fail (a full disk, an I/O error) at a chosen place. Used by one thread.

#include <cstdint>
#include <memory>
#include <string>

#include "plexus/proto/bytes.hpp"

namespace plexus::mcap {

/// A file written at explicit offsets. Each call answers 0 or the errno of its failure.
class OutputFile {
public:
    virtual ~OutputFile() = default;
    /// Writes all of `bytes` at `offset`; on failure a part of them may have been written.
    virtual int write_at(std::uint64_t offset, proto::ByteView bytes) = 0;
    /// Allocates disk space for [offset, offset + length) without changing the file's size
    /// (fallocate with FALLOC_FL_KEEP_SIZE); EOPNOTSUPP when the file system cannot.
    virtual int reserve(std::uint64_t offset, std::uint64_t length) = 0;
    /// Sets the file's size.
    virtual int truncate(std::uint64_t length) = 0;
    /// Makes what was written durable (fdatasync).
    virtual int sync() = 0;
    /// The path, for error messages.
    virtual const std::string& path() const = 0;
};

/// Creates a new file at `path` (mode 0644); never replaces an existing file.
proto::Result<std::unique_ptr<OutputFile>> create_output_file(const std::string& path);

}  // namespace plexus::mcap
