#pragma once
// Threading: a region is made on its writer's thread; its slots are held and freed, and readers
// added, on the threads of its readers too (`--threads`): what reaches a connection (the writer's
// shm_free, a reader's shm_region_gone) is handed to that connection's own thread.
//
// Shared memory between a client and its local daemon, for large payloads (PROTOCOL.md, "Shared
// memory"). The daemon creates a region per written port on the writer's request and sends it the
// region read-write; the writer copies a payload into a slot of it and sends only the slot's place
// (a data_shm frame). When every reader of the port is a local client that maps regions, the place
// is passed on as it is: each reader gets the region read-only, copies the payload out and
// releases it, and once every reference to the slot is gone the writer is told it is free
// (shm_free). Otherwise the daemon copies the payload out at once and the message goes on as any
// other: monitors, arbitration and links never see a region.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "../core/message.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::daemon {

class FramedConnection;

/// Bytes of shared memory the daemon's regions hold together, against its configured cap.
/// Atomic: payloads are held and freed on the writers' data threads (`--threads`).
struct ShmUsage {
    std::atomic<std::size_t> bytes{0};
    std::atomic<std::size_t> regions{0};
    std::atomic<std::size_t> slots{0};  ///< payloads held for readers in all regions
};

/// One region: a sealed memfd (it can neither shrink nor grow, so nobody can make a mapping of it
/// fault), mapped read-only by the daemon, which reads it only to copy a payload out.
class ShmRegion {
public:
    /// Creates a region of `size` bytes for the port the writer writes.
    static proto::Result<std::shared_ptr<ShmRegion>> create(std::uint64_t id, std::size_t size,
                                                            std::weak_ptr<FramedConnection> writer,
                                                            std::shared_ptr<ShmUsage> usage);
    /// Tells the readers it was sent to that it is gone, then unmaps and closes it.
    ~ShmRegion();
    ShmRegion(const ShmRegion&) = delete;
    ShmRegion& operator=(const ShmRegion&) = delete;

    std::uint64_t id() const { return id_; }
    std::size_t size() const { return size_; }
    const std::uint8_t* data() const { return data_; }
    /// The descriptor the writer gets: read-write.
    int writer_fd() const { return writer_fd_; }
    /// The descriptor readers get: opened read-only, so a reader cannot write into the writer's slots.
    int reader_fd() const { return reader_fd_; }
    /// True when [offset, offset + length) lies inside the region.
    bool holds(std::uint64_t offset, std::uint64_t length) const {
        return offset <= size_ && length <= size_ - offset;
    }

    /// Remembers a connection the region was sent to, to tell it when the region is gone (and
    /// forgets those already gone, so that a long-lived region does not collect them). Any thread.
    void add_reader(std::weak_ptr<FramedConnection> reader);
    /// Makes sure no one can write into the region but through the writer's mapping, which it made
    /// when it got the region: seals future writes (F_SEAL_FUTURE_WRITE) the first time. Without
    /// it a reader could reopen its descriptor read-write through /proc. False if that cannot be
    /// done (the writer sealed the seals first): then payloads are copied out, never shared.
    /// On the writer's thread.
    bool seal_for_readers();
    /// Counts a slot held by a message (see ShmSlot).
    void hold() { ++usage_->slots; }
    /// The slot at `offset` is no longer held: tells the writer it is free again. Any thread.
    void free(std::uint64_t offset);

private:
    ShmRegion(std::uint64_t id, std::size_t size, std::weak_ptr<FramedConnection> writer,
              std::shared_ptr<ShmUsage> usage)
        : id_(id), size_(size), writer_(std::move(writer)), usage_(std::move(usage)) {}

    std::uint64_t id_;
    std::size_t size_;
    int writer_fd_ = -1;
    int reader_fd_ = -1;
    const std::uint8_t* data_ = nullptr;
    std::weak_ptr<FramedConnection> writer_;
    std::shared_ptr<ShmUsage> usage_;
    std::mutex readers_mutex_;  ///< readers on several data threads add themselves
    std::vector<std::weak_ptr<FramedConnection>> readers_;
    enum class ReaderSeal { unknown, sealed, impossible } reader_seal_ = ReaderSeal::unknown;
};

/// A payload in a region, held while any message refers to it; frees its slot when the last goes.
struct ShmSlot {
    ShmSlot(std::shared_ptr<ShmRegion> region_, std::uint64_t offset_, std::uint64_t length_)
        : region(std::move(region_)), offset(offset_), length(length_) {
        region->hold();
    }
    ~ShmSlot() { region->free(offset); }
    ShmSlot(const ShmSlot&) = delete;
    ShmSlot& operator=(const ShmSlot&) = delete;

    std::shared_ptr<ShmRegion> region;
    std::uint64_t offset;
    std::uint64_t length;
};

/// The message with its payload copied out of shared memory into a record of its own.
Message copy_out_of_shm(const Message& message);

}  // namespace plexus::daemon
