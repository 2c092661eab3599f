#pragma once
// Threading: every function may be called from any thread (one mutex, held for a few moves).
//
// Buffers for large received blobs, recycled. A 1 MiB blob received into fresh memory costs the
// kernel 256 page faults, each zeroing a page, before the copy can write it: as much as the copy
// itself. A reader that hands its buffers back (plexus::recycle_blob; the Python module does it
// when an array dies) receives the next blobs into memory already mapped.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace plexus::detail {

/// An empty vector with room for at least `size` bytes: a recycled one when one fits (not more
/// than four times too large), else a new one.
std::vector<std::uint8_t> take_blob_buffer(std::size_t size);

/// Keeps the memory of `bytes` for a later take_blob_buffer, within a bound (a few buffers, a few
/// tens of MiB: the oldest kept goes first); a buffer smaller than a large payload is just freed.
void keep_blob_buffer(std::vector<std::uint8_t>&& bytes);

}  // namespace plexus::detail
