#pragma once
// Threading: one io_context thread; one Outbox per socket.

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <set>
#include <vector>

#include "../core/reader_queue.hpp"
#include "asio.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::daemon {

class FramedConnection;
class ShmRegion;
struct ShmSlot;

/// A queue of messages that leaves on this socket as data frames tagged with `handle`.
struct OutSource {
    std::uint64_t handle = 0;
    ReaderQueue* queue = nullptr;
    std::uint64_t* sent_counter = nullptr;  ///< incremented per message written; may be null
    std::shared_ptr<void> keep_alive;       ///< owns what `queue` points into
    /// Its qos.prio (0-7, higher first), asked once per fill(); null means 0.
    std::function<int()> priority;
};

/// One gathered write: buffers point into `control`, `flat` and the kept messages. Small records
/// are copied into `flat` with their frame headers, so a batch of thousands of small messages is a
/// handful of buffers (Asio sends at most 64 buffers per system call); large records are sent from
/// where they are.
struct Batch {
    std::vector<asio::const_buffer> buffers;
    std::vector<Message> messages;  ///< the large records referenced by `buffers`
    std::vector<proto::Bytes> control;
    proto::Bytes flat;
    std::size_t bytes = 0;
    std::size_t largest = 0;  ///< the largest record or batch of records in it
    /// Descriptors of shared-memory regions, sent with the batch's first byte (SCM_RIGHTS): the
    /// shm_region frames they belong to are in the batch, so each arrives no later than its frame.
    std::vector<int> fds;
    std::vector<std::shared_ptr<const ShmRegion>> regions;  ///< keep `fds` open until written
    /// The batch ends with the `rings` answer: everything after it goes through the rings.
    bool then_rings = false;
    std::vector<std::shared_ptr<const void>> keep;  ///< keeps other descriptors open until written
    void clear();
    bool empty() const { return buffers.empty(); }
};

/// Everything waiting to be written on one socket: control frames first, then data frames,
/// gathered so that many small frames leave in one system call. Sources are served by strict
/// priority (`qos.prio`): while a source of a higher priority has messages, no lower one puts any
/// into the batch; sources of equal priority take turns, one message each (round robin). "Served
/// first" therefore means: into the same write, and ahead of everything of lower priority in it.
/// A lower source waits at most for what its higher ones hold when the batch is made; priorities
/// are read once per batch, so a batch in the making is not reordered.
class Outbox {
public:
    /// `on_space` runs when a strict queue drops below capacity (wakes writers held back).
    explicit Outbox(std::function<void()> on_space) : on_space_(std::move(on_space)) {}

    void push_control(proto::Bytes frame) {
        control_bytes_ += frame.size();
        control_.push_back({std::move(frame), nullptr});
    }
    /// Queues a shm_region frame giving `region` to the writer, with its read-write descriptor.
    void push_writer_region(std::shared_ptr<const ShmRegion> region);
    /// Queues the `rings` answer with its descriptors (kept open by `keep` until written). It ends
    /// its batch: the frames after it are written into the rings, not the socket.
    void push_rings_answer(proto::Bytes frame, std::vector<int> fds, std::shared_ptr<const void> keep);
    /// Bytes of control frames (replies, errors) not yet handed to the socket.
    std::size_t control_bytes() const { return control_bytes_; }
    /// Control frames not yet handed to the socket (a tiny frame costs a heap block of its own).
    std::size_t control_frames() const { return control_.size(); }
    void add_source(OutSource source) { sources_.push_back(std::move(source)); }
    void remove_source(std::uint64_t handle);
    bool empty() const;

    /// Moves frames worth about `budget` bytes (at least one frame) into `batch`.
    void fill(Batch& batch, std::size_t budget);

    // --- shared memory (see shm_region.hpp) ---
    /// The connection this outbox writes to, which regions sent to it remember.
    void set_owner(std::weak_ptr<FramedConnection> owner) { owner_ = std::move(owner); }
    /// The reader is done with the `count` oldest shared-memory messages sent to it; false if it
    /// was not sent that many.
    bool release(std::uint64_t count);
    /// Lets go of every shared-memory message sent (the connection closed).
    void release_all() { lent_.clear(); }
    /// Shared-memory messages sent and not yet released.
    std::size_t lent() const { return lent_.size(); }
    /// More unreleased than this and the peer is cut off: a client releases what each read brings,
    /// so only a broken one gets here, and each entry holds a slot of some writer's region. A
    /// reader that does not read at all stops at what its socket buffer takes, far below.
    static constexpr std::size_t max_lent = 1u << 18;
    /// Called for each shared-memory message this outbox copies out instead of lending it (its
    /// peer holds max_regions others): the daemon counts them.
    void on_shm_copy(std::function<void()> count) { on_shm_copy_ = std::move(count); }
    /// The region is gone: a later region is sent again even if it had the same id.
    void forget_region(std::uint64_t id) { regions_sent_.erase(id); }
    /// True when the region was sent on this connection (and is not gone).
    bool has_region(std::uint64_t id) const { return regions_sent_.contains(id); }
    /// Regions sent on this connection and not gone: each holds a descriptor in the peer.
    std::size_t regions_held() const { return regions_sent_.size(); }
    /// At most this many regions are sent to one peer; messages of further regions are copied
    /// out here, on the reader's own thread, where what it was sent is known. Descriptors a peer has not read
    /// yet count against the daemon's own descriptor limit.
    static constexpr std::size_t max_regions = 64;

private:
    struct ControlFrame {
        proto::Bytes bytes;
        std::shared_ptr<const ShmRegion> writer_region;  ///< its read-write fd goes with the frame
        std::vector<int> fds{};                          ///< the rings answer's descriptors
        std::shared_ptr<const void> keep{};              ///< keeps `fds` open
        bool then_rings = false;
    };
    /// Writes the head of a request's call frame and hands its ticket on to this socket; false (and
    /// nothing written) when its deadline has passed.
    bool start_call_frame(Batch& batch, std::uint64_t handle, const Message& message);
    /// Adds the frame of a shared-memory message, preceded by its region the first time.
    void add_shm_message(Batch& batch, std::uint64_t handle, Message message);

    std::function<void()> on_space_;
    std::function<void()> on_shm_copy_;
    std::deque<ControlFrame> control_;
    std::size_t control_bytes_ = 0;
    std::vector<OutSource> sources_;
    std::vector<int> priorities_;  ///< of sources_, read at the start of fill()
    std::size_t next_source_ = 0;
    std::weak_ptr<FramedConnection> owner_;
    std::deque<std::shared_ptr<const ShmSlot>> lent_;  ///< in the order sent, released in that order
    std::set<std::uint64_t> regions_sent_;
};

}  // namespace plexus::daemon
