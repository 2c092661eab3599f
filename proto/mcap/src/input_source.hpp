#pragma once
// Where the reader's bytes come from: a file read with pread as needed (a recording may be larger
// than memory), or bytes already in memory (the fuzz target). Used by one thread at a time.

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "plexus/proto/bytes.hpp"

namespace plexus::mcap {

class InputSource {
public:
    virtual ~InputSource() = default;
    virtual std::uint64_t size() const = 0;
    /// Fills `out` with the bytes at `offset`; an Error naming the offset when they cannot be read.
    virtual proto::Status read(std::uint64_t offset, std::span<std::uint8_t> out) const = 0;
};

/// Opens `path` for reading.
proto::Result<std::unique_ptr<InputSource>> open_file_source(const std::string& path);
/// Serves `bytes`.
std::unique_ptr<InputSource> memory_source(proto::Bytes bytes);

/// Reads `length` bytes at `offset` into `out` (resized); the caller has checked `length` against
/// the file's size and its own limit.
proto::Status read_bytes(const InputSource& source, std::uint64_t offset, std::uint64_t length,
                         proto::Bytes& out);

}  // namespace plexus::mcap
