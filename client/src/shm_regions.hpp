#pragma once
// Threading: two sides. The writer side (regions this client writes large payloads into) may be
// used from any thread and is guarded by mutex_ (only ReadDemand's is taken while it is held),
// never held while blocking on the socket or waiting for a reply; a writer waiting for a free slot waits on
// `freed_` under it. The reader side (regions payloads are copied out of) is touched only by Connection's
// receiving thread, without a lock. client/src/LOCK_ORDER.md has the whole order.
//
// The shared-memory regions of one connection. The daemon gives each port that writes large
// payloads a region (with a shm_region frame and its descriptor, before the reply to the request
// that asked for it), frees slots with shm_free once every reader released them, and gives each
// reading client the regions it reads data_shm payloads from.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "inbox.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/shm.hpp"
#include "read_demand.hpp"
#include "shm_lease.hpp"
#include "shm_slots.hpp"

namespace plexus::detail {

/// A region the daemon gave this client to write the large payloads of one port into.
struct WriterRegion {
    WriterRegion(std::uint64_t id_, int fd_, std::uint8_t* data_, std::size_t size_)
        : id(id_), fd(fd_), data(data_), size(size_), slots(size_) {}
    ~WriterRegion();
    WriterRegion(const WriterRegion&) = delete;
    WriterRegion& operator=(const WriterRegion&) = delete;
    const std::uint64_t id;
    const int fd;
    std::uint8_t* const data;
    const std::size_t size;
    ShmSlots slots;        ///< guarded by ShmRegions::mutex_
    bool stalled = false;  ///< stayed full for a whole wait: do not wait again until a slot is freed
};

class ShmRegions {
public:
    /// A writer waiting for a free slot registers with `demand` (which must outlive this).
    explicit ShmRegions(ReadDemand& demand) : demand_(demand) {}
    ~ShmRegions();
    ShmRegions(const ShmRegions&) = delete;
    ShmRegions& operator=(const ShmRegions&) = delete;

    // --- the writer side, any thread ---

    /// The daemon said whether it shares memory with this client (Connection::enable_shm).
    void enable(bool on);
    /// What is known of the region of port `handle`: nullopt when the daemon was not asked yet
    /// (the caller asks it, then calls assign()); null when the port writes through the socket.
    std::optional<std::shared_ptr<WriterRegion>> writer_region(std::uint64_t handle);
    /// Records the daemon's answer for `handle`: region `id` (its frame came before the reply, so
    /// it is here) or none. The region, or null.
    std::shared_ptr<WriterRegion> assign(std::uint64_t handle, std::optional<std::uint64_t> id);
    /// A slot of `length` bytes in `region`, waiting up to `wait` for the daemon's shm_free frames
    /// when it is full; nullopt when none came (the region is then stalled: later writes take the
    /// socket at once, until a slot is freed).
    std::optional<std::size_t> allocate(WriterRegion& region, std::size_t length,
                                        std::chrono::steady_clock::duration wait);
    /// The port `handle` closed: its region goes with it (the daemon drops its side too).
    void forget(std::uint64_t handle);

    // --- the receiving thread only ---

    /// Handles a shm_region (taking its descriptor from the front of `fds`), shm_free or
    /// shm_region_gone frame; the reason when the frame is bad and the connection must end.
    std::optional<std::string> on_frame(proto::FrameType type, proto::ByteView fields, std::deque<int>& fds);
    /// Why a data_shm frame points at no valid place in a region read from; nullopt when it is valid.
    std::optional<std::string> check(const proto::ShmDataView& data) const;
    /// A checked data_shm frame's message, left in its region and held there (`ticket` of `book`)
    /// until the segment goes.
    InboxSegment lease(const proto::ShmDataView& data, std::shared_ptr<ReleaseBook> book,
                       std::uint64_t ticket) const;
    /// Copies a held payload out (a blob straight into its Value); the lease is let go of after.
    static Received copy_out(const ShmLease& lease);
    /// Gives back a slot taken by allocate() and never sent (a loan not sent).
    void give_back(WriterRegion& region, std::size_t offset);

private:
    ReadDemand& demand_;
    std::mutex mutex_;
    std::condition_variable freed_;  ///< a slot was freed
    bool enabled_ = false;
    std::map<std::uint64_t, std::shared_ptr<WriterRegion>> writer_regions_;  ///< by region id
    std::map<std::uint64_t, std::optional<std::uint64_t>> port_regions_;     ///< handle -> region id

    /// Regions this client reads payloads of data_shm frames from, mapped read-only, by id; the
    /// receiving thread's. A lease keeps its mapping after the region is gone.
    std::map<std::uint64_t, std::shared_ptr<const ReaderMapping>> reader_regions_;
};

}  // namespace plexus::detail
