#pragma once
// Frames of the shared-memory path between a client and its local daemon (PROTOCOL.md, "Shared
// memory"). A writer's large payload is copied once into a region the daemon created for its port;
// the socket carries only where it is. Regions travel as file descriptors (SCM_RIGHTS) attached to
// the write that carries their shm_region frame.

#include <cstdint>
#include <string_view>
#include <utility>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"

namespace plexus::proto {

/// Where a payload lies in a region.
struct ShmPlace {
    std::uint64_t region = 0;
    std::uint64_t offset = 0;
    std::uint64_t length = 0;
};

/// The fields of a data_shm frame after its handle.
struct ShmPlaceView {
    ShmPlace place;
    ByteView head;  ///< the record without its payload: source | seq | time_ns
};

struct ShmDataView {
    std::uint64_t handle = 0;
    ShmPlace place;
    ByteView head;            ///< the record without its payload: source | seq | time_ns
    ByteView place_and_head;  ///< the fields after the handle, as they are passed on to readers
};

/// Appends the fields of a data_shm frame after its handle: region, offset, length, record head.
void append_shm_place(Bytes& out, const ShmPlace& place, std::string_view source, std::uint64_t seq,
                      std::uint64_t time_ns);
/// Appends the header and handle of a data_shm frame whose `rest_size` bytes (as append_shm_place
/// writes them) follow.
void append_shm_frame_prefix(Bytes& out, std::uint64_t handle, std::size_t rest_size);
/// Decodes the fields of a data_shm frame; the head must be a whole record head with nothing after.
Result<ShmDataView> decode_shm_data(ByteView fields);
/// Decodes the fields after the handle.
Result<ShmPlaceView> decode_shm_place(ByteView place_and_head);

struct ShmRegionView {
    std::uint64_t region = 0;
    std::uint64_t size = 0;
    bool writable = false;
};
Bytes make_shm_region_frame(const ShmRegionView& region);
Result<ShmRegionView> decode_shm_region(ByteView fields);

/// A frame of one varint (shm_release: a count; shm_region_gone: a region).
Bytes make_shm_number_frame(FrameType type, std::uint64_t number);
Result<std::uint64_t> decode_shm_number(ByteView fields, std::string_view what);

Bytes make_shm_free_frame(std::uint64_t region, std::uint64_t offset);
/// The region and offset of a shm_free frame.
Result<std::pair<std::uint64_t, std::uint64_t>> decode_shm_free(ByteView fields);

}  // namespace plexus::proto
