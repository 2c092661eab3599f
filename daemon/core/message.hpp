#pragma once
// Threading: values; safe to copy between threads, but the daemon uses them on its one thread.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string_view>

#include "plexus/proto/bytes.hpp"

namespace plexus::daemon {

struct ShmSlot;    // net/shm_region.hpp
class CallTicket;  // call_ticket.hpp

/// A block of bytes read from a socket, left uninitialized on allocation: zero-filling a 1 MiB
/// frame before reading into it would cost as much as the read itself.
struct Chunk {
    explicit Chunk(std::size_t n) : bytes(new std::uint8_t[n]), size(n) {}
    std::unique_ptr<std::uint8_t[]> bytes;
    std::size_t size;
    std::uint8_t* data() { return bytes.get(); }
    const std::uint8_t* data() const { return bytes.get(); }
};

/// A message as the daemon moves it: the encoded record, never re-encoded, kept alive by the
/// chunk it was read into. Copying a Message copies a pointer, not the payload.
///
/// A Message may also be a *batch*: the records of a data_batch frame (consecutive writes of one
/// port), each `varint length | record`, moved as one unit where nothing needs to look at them one
/// by one (see batch.hpp). Counters and queue bounds count the records, not the unit.
struct Message {
    std::shared_ptr<const Chunk> storage;
    proto::ByteView record;  ///< one record, or a batch's length-prefixed records
    std::uint64_t seq = 0;
    std::uint32_t batch = 0;  ///< 0: one record; n > 0: a batch of n records
    /// Set for a payload left in a writer's shared memory: then `record` holds the fields of a
    /// data_shm frame after its handle (region, offset, length, record head), and the message only
    /// ever goes to local clients that map regions (see net/shm_region.hpp).
    std::shared_ptr<const ShmSlot> shm{};
    /// How many monitors' publish calls led to this message (0: a component wrote it). A monitor
    /// that publishes into a connection whose monitor publishes again... is cut off past a few.
    std::uint8_t publish_depth = 0;
    /// Set for a request (request/reply): its ticket in this daemon's call table. Null for data.
    std::shared_ptr<CallTicket> call{};

    /// How many messages this unit carries.
    std::uint64_t count() const { return batch == 0 ? 1 : batch; }
};

}  // namespace plexus::daemon
