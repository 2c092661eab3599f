#pragma once
// Threading: every member may be called from any thread. One mutex (mutex_) guards everything here;
// only ReadDemand's mutex is taken while it is held, and it is never held while blocking on the
// socket (client/src/LOCK_ORDER.md). Connection's receiving thread delivers; ports and
// requesters wait, each on a condition variable of its own.
//
// The reply/inbox demultiplexer: what the receiving thread decoded goes to whoever waits for it.
// Two ways to be waited for, kept apart from what the frames are:
//   - by id (`Awaited`): a control reply by its request id. A future `answer` frame (the reply to
//     a `call` to a served port) is a second Awaited keyed by call id: deliver_*, wait_* as for
//     replies, or, for a caller that does not wait, a completion kept in place of the slot and
//     returned by the delivering method (so that the receiver runs it outside the lock; this
//     class never calls out).
//   - by handle (the inboxes): data records, in order, for the port that reads them. A future
//     `call` frame is delivered by handle like data (its call id inside its segment).

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "inbox.hpp"
#include "plexus/proto/control.hpp"
#include "read_demand.hpp"

namespace plexus::detail {

using Clock = std::chrono::steady_clock;

/// One record of a received block and the handle it goes to.
struct Delivery {
    std::uint64_t handle = 0;
    proto::ByteView record;  ///< a view into the block it is delivered with
};

/// Values awaited by id, each kept from its delivery until its waiter takes it. No lock of its
/// own: the Demux's mutex guards it.
template <class T>
class Awaited {
public:
    /// A new id, awaited from now on.
    std::uint64_t add() {
        const std::uint64_t id = next_id_++;
        slots_[id];
        return id;
    }
    /// Keeps `value` for its waiter; false when nobody awaits `id` (it gave up, or never asked).
    bool fill(std::uint64_t id, T&& value) {
        const auto slot = slots_.find(id);
        if (slot == slots_.end())
            return false;
        slot->second = std::move(value);
        return true;
    }
    bool ready(std::uint64_t id) const {
        const auto slot = slots_.find(id);
        return slot != slots_.end() && slot->second.has_value();
    }
    /// Stops awaiting `id`; what was delivered for it, if anything.
    std::optional<T> take(std::uint64_t id) {
        auto node = slots_.extract(id);
        return node.empty() ? std::nullopt : std::move(node.mapped());
    }

private:
    std::uint64_t next_id_ = 1;
    std::map<std::uint64_t, std::optional<T>> slots_;
};

/// Demultiplexes what one connection receives: replies to their requesters, records to the
/// inboxes of their ports. Also holds whether the connection broke, and why.
class Demux {
public:
    /// `description` names the connection in the reason a broken connection gives ("connection
    /// to DESCRIPTION lost: why").
    /// Waits register with `demand` (which must outlive this), so that the socket is read for them.
    Demux(std::string description, ReadDemand& demand)
        : description_(std::move(description)), demand_(demand) {}
    Demux(const Demux&) = delete;
    Demux& operator=(const Demux&) = delete;

    // --- replies, by request id ---

    /// A new request id whose reply is kept until wait_reply() (or cancel_reply()) takes it.
    std::uint64_t expect_reply();
    /// Stops waiting for the reply of `id` (its request could not be sent).
    void cancel_reply(std::uint64_t id);
    /// Hands a reply to its requester; a reply nobody waits for any more is dropped.
    void deliver_reply(proto::Reply reply);
    /// The reply to `id`, waiting until `deadline`; nullopt when it did not come in time. Throws
    /// Error (refused) when the connection broke before it came. Stops waiting for `id` either way.
    std::optional<proto::Reply> wait_reply(std::uint64_t id, Clock::time_point deadline);

    // --- records, by handle ---

    /// Appends `records` (views into `block`) to the inboxes of their handles, in order: one lock
    /// and one segment per run of records for one handle. Records for closed handles are dropped.
    void deliver(const std::shared_ptr<const proto::Bytes>& block, std::span<const Delivery> records);
    /// Appends one segment (a message received whole, or copied out of shared memory) for `handle`.
    void deliver(std::uint64_t handle, InboxSegment segment);
    /// False once `handle` is closed: a receiver need not build what would be dropped.
    bool accepts(std::uint64_t handle) const;
    /// Moves everything delivered to `handle` so far into `into` (which must be empty), waiting up
    /// to `timeout` for the first; false if none came. Throws Error (refused) when the connection
    /// broke and nothing is left for `handle`.
    bool take_all(std::uint64_t handle, std::chrono::milliseconds timeout, std::deque<InboxSegment>& into);
    /// What take_all would take now, without waiting and without asking for a read: false when
    /// nothing is there (or the handle is closed); throws Error (refused) when broken and empty.
    bool take_now(std::uint64_t handle, std::deque<InboxSegment>& into);
    /// Drops what is kept for `handle` and everything that still comes for it (handles are never reused).
    void close(std::uint64_t handle);

    // --- the connection's state ---

    /// Marks the connection broken (the first reason stays) and wakes every waiter.
    void fail(const std::string& why);
    /// One load.
    bool broken() const { return is_broken_.load(std::memory_order_acquire); }
    /// Throws Error (refused) with the reason when broken.
    void throw_if_broken() const;

private:
    /// The records kept for one handle, and how its reader waits for them. Shared with a waiting
    /// reader, so that close() can drop it while that reader still waits on `ready`.
    struct Box {
        std::deque<InboxSegment> segments;
        std::condition_variable ready;
        int waiting = 0;      ///< readers waiting on `ready`: a delivery notifies only when there are
        bool closed = false;  ///< close() dropped it: its waiting reader returns
        int demanding = 0;    ///< waiting readers still counted in ReadDemand (none once records came)
    };
    /// The box of `handle`, made on first use; null when `handle` is closed.
    Box* box_locked(std::uint64_t handle);

    /// Ends the demand of the readers of `box` (records came, or it closed).
    void satisfy_locked(Box& box);

    const std::string description_;
    ReadDemand& demand_;
    mutable std::mutex mutex_;
    std::condition_variable replied_;  ///< a reply came, or the connection broke
    Awaited<proto::Reply> replies_;
    std::set<std::uint64_t> demanding_replies_;  ///< requesters still counted in ReadDemand
    std::map<std::uint64_t, std::shared_ptr<Box>> boxes_;
    std::set<std::uint64_t> closed_;
    std::string broken_;
    std::atomic<bool> is_broken_{false};  ///< broken_ is set; read without the lock
};

}  // namespace plexus::detail
