#include "demux.hpp"

namespace plexus::detail {

namespace {
// How long a read with a timeout of zero waits for the receiving thread's one look at the socket.
constexpr auto poll_bound = std::chrono::milliseconds(10);
}  // namespace

std::uint64_t Demux::expect_reply() {
    std::lock_guard lock(mutex_);
    return replies_.add();
}

void Demux::cancel_reply(std::uint64_t id) {
    std::lock_guard lock(mutex_);
    replies_.take(id);
}

void Demux::deliver_reply(proto::Reply reply) {
    {
        std::lock_guard lock(mutex_);
        const std::uint64_t id = reply.id;
        if (!replies_.fill(id, std::move(reply)))
            return;
        if (demanding_replies_.erase(id) > 0)
            demand_.remove();
    }
    // All of them: the few requests in flight share one condition variable.
    replied_.notify_all();
}

std::optional<proto::Reply> Demux::wait_reply(std::uint64_t id, Clock::time_point deadline) {
    std::unique_lock lock(mutex_);
    if (!replies_.ready(id) && broken_.empty()) {
        demanding_replies_.insert(id);
        demand_.add(deadline);
        replied_.wait_until(lock, deadline, [&] { return replies_.ready(id) || !broken_.empty(); });
        if (demanding_replies_.erase(id) > 0)
            demand_.remove();
    }
    auto reply = replies_.take(id);
    if (!reply && !broken_.empty())
        throw Error(ErrorCode::refused, broken_);
    return reply;
}

Demux::Box* Demux::box_locked(std::uint64_t handle) {
    auto& box = boxes_[handle];
    if (!box) {
        // Handles are never reused: data for any handle not closed is kept, even for one whose open
        // reply is still on its way to the requester, so that nothing arriving with the reply is lost.
        if (closed_.contains(handle)) {
            boxes_.erase(handle);
            return nullptr;
        }
        box = std::make_shared<Box>();
    }
    return box.get();
}

void Demux::deliver(const std::shared_ptr<const proto::Bytes>& block, std::span<const Delivery> records) {
    // Readers are woken after the lock is released, so that they do not wake only to wait for it;
    // a box stays alive for that (close() may drop it meanwhile) through these references.
    std::vector<std::shared_ptr<Box>> wake;
    {
        std::lock_guard lock(mutex_);
        std::optional<std::uint64_t> run_handle;
        InboxSegment* run = nullptr;  // the segment of the current run of records for one handle
        for (const auto& data : records) {
            if (data.handle != run_handle) {
                run_handle = data.handle;
                run = nullptr;
                if (Box* box = box_locked(data.handle)) {
                    run = &box->segments.emplace_back(InboxSegment{block, {}, std::nullopt, nullptr});
                    satisfy_locked(*box);
                    if (box->waiting > 0)
                        wake.push_back(boxes_[data.handle]);
                }
            }
            if (run)
                run->records.push_back(data.record);
        }
    }
    for (const auto& box : wake)
        box->ready.notify_one();
}

void Demux::deliver(std::uint64_t handle, InboxSegment segment) {
    std::shared_ptr<Box> wake;
    {
        std::lock_guard lock(mutex_);
        Box* box = box_locked(handle);
        if (!box)
            return;
        box->segments.push_back(std::move(segment));
        satisfy_locked(*box);
        if (box->waiting > 0)
            wake = boxes_[handle];
    }
    if (wake)
        wake->ready.notify_one();
}

bool Demux::accepts(std::uint64_t handle) const {
    std::lock_guard lock(mutex_);
    return !closed_.contains(handle);
}

bool Demux::take_all(std::uint64_t handle, std::chrono::milliseconds timeout,
                     std::deque<InboxSegment>& into) {
    std::unique_lock lock(mutex_);
    auto take = [&]() -> bool {
        const auto found = boxes_.find(handle);
        if (found == boxes_.end() || found->second->segments.empty())
            return false;
        into.swap(found->second->segments);
        return true;
    };
    if (take())
        return true;
    if (!broken_.empty())
        throw Error(ErrorCode::refused, broken_);
    if (closed_.contains(handle))
        return false;
    if (timeout.count() <= 0) {
        // A poll still looks at the socket once, without waiting: otherwise it would only ever
        // see what another wait happened to have read.
        lock.unlock();
        demand_.poll(poll_bound);
        lock.lock();
        if (take())
            return true;
        if (!broken_.empty())
            throw Error(ErrorCode::refused, broken_);
        return false;
    }
    // Held while waiting: close() may drop the box from the map meanwhile.
    auto& entry = boxes_[handle];
    if (!entry)
        entry = std::make_shared<Box>();
    const std::shared_ptr<Box> box = entry;
    ++box->waiting;
    ++box->demanding;
    // Only now is the clock read: it costs as much as the rest of a read.
    const auto deadline = Clock::now() + timeout;
    demand_.add(deadline);
    box->ready.wait_until(lock, deadline,
                          [&] { return !box->segments.empty() || box->closed || !broken_.empty(); });
    --box->waiting;
    if (box->demanding > 0) {
        --box->demanding;
        demand_.remove();
    }
    if (!box->segments.empty()) {
        into.swap(box->segments);
        return true;
    }
    if (!broken_.empty())
        throw Error(ErrorCode::refused, broken_);
    return false;
}

bool Demux::take_now(std::uint64_t handle, std::deque<InboxSegment>& into) {
    std::lock_guard lock(mutex_);
    const auto found = boxes_.find(handle);
    if (found != boxes_.end() && !found->second->segments.empty()) {
        into.swap(found->second->segments);
        return true;
    }
    if (!broken_.empty())
        throw Error(ErrorCode::refused, broken_);
    return false;
}

void Demux::satisfy_locked(Box& box) {
    // Counted out here, not when the reader wakes: the receiving thread asks right after this
    // delivery whether anyone still needs the socket read, and a reader that has what it waited
    // for does not (reading on for it would read ahead of the ports).
    if (box.demanding == 0)
        return;
    demand_.remove(box.demanding);
    box.demanding = 0;
}

void Demux::close(std::uint64_t handle) {
    std::shared_ptr<Box> box;
    {
        std::lock_guard lock(mutex_);
        closed_.insert(handle);
        const auto found = boxes_.find(handle);
        if (found == boxes_.end())
            return;
        box = std::move(found->second);
        boxes_.erase(found);
        box->segments.clear();
        box->closed = true;
        satisfy_locked(*box);
    }
    box->ready.notify_all();
}

void Demux::fail(const std::string& why) {
    std::vector<std::shared_ptr<Box>> wake;
    {
        std::lock_guard lock(mutex_);
        if (broken_.empty())
            broken_ = "connection to " + description_ + " lost: " + why;
        is_broken_.store(true, std::memory_order_release);
        for (const auto& [handle, box] : boxes_) {
            if (box->waiting > 0)
                wake.push_back(box);
        }
    }
    replied_.notify_all();
    for (const auto& box : wake)
        box->ready.notify_all();
}

void Demux::throw_if_broken() const {
    if (!is_broken_.load(std::memory_order_acquire))
        return;  // every write checks: no lock on the way when all is well
    std::lock_guard lock(mutex_);
    throw Error(ErrorCode::refused, broken_);
}

}  // namespace plexus::detail
