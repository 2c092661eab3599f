#pragma once
// zstd for chunk records. Decompression never produces more than the size the chunk declares,
// and grows its buffer only as output actually appears: a lying size field costs nothing.

#include <cstdint>
#include <string>

#include "plexus/proto/bytes.hpp"

namespace plexus::mcap {

/// `input` compressed at `level` into `out` (replacing its contents); an Error names zstd's reason.
proto::Status zstd_compress(proto::ByteView input, int level, proto::Bytes& out);

/// Decompresses `input` (one or more zstd frames) into `out`, which must come to exactly
/// `expected_size` bytes. Errors are plain reasons ("the data ends inside a zstd frame"); the
/// caller adds where.
proto::Status zstd_decompress(proto::ByteView input, std::uint64_t expected_size, proto::Bytes& out);

}  // namespace plexus::mcap
